"""The service's settings, from the environment (prefix SCREWCAL_) or arguments."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field
from pydantic_settings import BaseSettings, SettingsConfigDict


class ServiceSettings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="SCREWCAL_")

    db_path: Path = Field(Path("screwcal.db"), description="the SQLite database file")
    host: str = Field("127.0.0.1", description="bind address: loopback unless told otherwise")
    port: int = 8080
    token: str = Field("", description="bearer token required to move a robot or change data, "
                                       "and to read; empty refuses every such request")
    read_token: str = Field("", description="a second token that may only read (jobs, "
                                            "measurements, results, reports), e.g. for a "
                                            "dashboard; empty: none")
    reconnect_interval_s: float = 0.5  # a paused job retries its links this often
    arm_timeout_s: float = 10.0  # waiting for the three holes of one pose
    pose_timeout_s: float = 120.0  # waiting for one pose of a running list
