"""The service's settings, from the environment (prefix SCREWCAL_) or arguments."""

from __future__ import annotations

from pathlib import Path

from pydantic import Field, field_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class ServiceSettings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="SCREWCAL_")

    db_path: Path = Field(Path("screwcal.db"), description="the SQLite database file")
    db_url: str = Field("", description="a postgresql:// URL: the job store on PostgreSQL, "
                        "where several services may share one database; empty: the SQLite "
                        "file db_path")
    lease_s: float = Field(10.0, gt=0, description="how long this service holds a job "
                           "unrenewed (it renews every third of this while it lives): how soon "
                           "another service on the same database resumes the jobs of one that "
                           "died")
    instance: str = Field("", description="this service's name on the jobs it holds; empty: "
                          "host:pid:random")
    drift_alarm_mm: float = Field(0.5, gt=0, description="a robot is flagged when the AP "
                                  "it measures now is this much worse than the AP its newest "
                                  "model reached (ISO 9283 AP, mm)")
    host: str = Field("127.0.0.1", description="bind address: loopback unless told otherwise")
    port: int = 8080
    token: str = Field("", description="bearer token required to move a robot or change data, "
                                       "and to read; empty refuses every such request")
    read_token: str = Field("", description="a second token that may only read (jobs, "
                                            "measurements, results, reports), e.g. for a "
                                            "dashboard; empty: none")
    tls_cert: Path | None = Field(None, description="the service's certificate (PEM): HTTPS")
    tls_key: Path | None = Field(None, description="its private key (PEM)")
    insecure_http: bool = Field(False, description="listen beyond loopback without TLS (tokens "
                                "and passwords then cross the network in clear)")
    reconnect_interval_s: float = 0.5  # a paused job retries its links and its store this often
    arm_timeout_s: float = 10.0  # waiting for the three holes of one pose
    pose_timeout_s: float = 120.0  # waiting for one pose of a running list
    max_concurrent_plans: int = Field(2, ge=1, description="job plans computed at once (each "
                                      "takes a worker thread); more requests wait")
    motion_tolerance_mm: float = Field(
        5.0, gt=0, description="an arm reading is refused when the distance it measured from "
        "the previous pose differs from the commanded one by more than this (plus "
        "motion_tolerance_rel of the distance): a stale, duplicated or early reading")
    motion_tolerance_rel: float = Field(0.3, ge=0, le=0.9, description="(an uncalibrated "
                                        "robot's errors change a motion by up to ~10 %)")
    motion_tolerance_deg: float = Field(6.0, gt=0, description="the same for the rotation "
                                        "angle between the two poses, degrees (plus "
                                        "motion_tolerance_rel of the angle); the thesis's "
                                        "Table 11 robot turns 2.3 deg more than commanded "
                                        "between two ISO 9283 cube poses")
    remeasure_attempts: int = Field(2, ge=0, description="fresh probes asked for a pose whose "
                                    "readings were all refused before the job pauses")
    beam_attempts: int = Field(3, ge=1, description="a tracker's pose whose beam stays broken "
                               "(after its search) this many times is skipped and counted, "
                               "never measured wrong")
    header_timeout_s: float = Field(10.0, gt=0, description="a client that has not sent its "
                                    "request within this is disconnected")
    max_connections: int = Field(200, ge=8, description="open connections beyond which new "
                                 "ones are answered 503 at once (the operator's room)")

    @field_validator("db_url")
    @classmethod
    def _postgres_only(cls, value: str) -> str:
        if value and not value.startswith(("postgresql://", "postgres://")):
            raise ValueError(f"db_url must be a postgresql:// URL (got {value.split(':')[0]}:..."
                             "); a SQLite database is a file path (db_path)")
        return value

    @property
    def db_target(self) -> str | Path:
        """Where the store is: the PostgreSQL URL when one is set, else the SQLite file."""
        return self.db_url or self.db_path
