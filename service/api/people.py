"""Users, their tokens, signing in, and the audit trail (administrators; a user manages their
own tokens)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, Request, status
from pydantic import BaseModel, ConfigDict, Field

from service.api.auth import Who, require
from service.audit import Event
from service.errors import CredentialsError
from service.people import People
from service.roles import Grant, Role

router = APIRouter(tags=["people"])


class SignIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(max_length=64)
    password: str = Field(max_length=1024)


class UserCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(max_length=64)
    role: Role
    password: str = Field(min_length=12, max_length=1024)


class RoleChange(BaseModel):
    model_config = ConfigDict(extra="forbid")
    role: Role


class TokenCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")
    label: str = Field("", max_length=80, description="what the token is for")
    days: float = Field(90.0, gt=0, le=3650, description="how long it lives")


def _people(request: Request) -> People:
    people: People = request.app.state.people
    return people


@router.post("/session")
def sign_in(body: SignIn, request: Request) -> dict[str, Any]:
    """A name and password for a token of one shift (8 h)."""
    source = request.client.host if request.client else "unknown"
    limit = request.app.state.sign_in_limit
    wait = limit.retry_after(source, body.name)
    if wait > 0:
        raise HTTPException(status.HTTP_429_TOO_MANY_REQUESTS, "too many failed sign-ins from "
                            f"this address: try again in {wait:.0f} s",
                            headers={"Retry-After": str(int(wait) + 1)})
    people = _people(request)
    try:
        who = people.check_password(body.name, body.password)
    except CredentialsError:
        limit.failed(source, body.name)
        request.app.state.audit.append(Event(body.name[:64], source, "sign-in", "session",
                                             "401 refused: name or password"))
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, "name or password refused") from None
    token, record = people.add_token(who.name, "session", 8 * 3600.0)
    request.state.principal = who
    return {"token": token, "role": who.role.value, "expires": record["expires"],
            "token_id": record["id"]}


@router.get("/users")
def list_users(_: Who, request: Request) -> list[dict[str, Any]]:
    return _people(request).users()


@router.post("/users", status_code=201)
def add_user(body: UserCreate, _: Who, request: Request) -> dict[str, Any]:
    return _people(request).add_user(body.name, body.role, body.password)


@router.put("/users/{name}/role")
def set_role(name: str, body: RoleChange, _: Who, request: Request) -> dict[str, Any]:
    return _people(request).set_role(name, body.role)


@router.post("/users/{name}/tokens", status_code=201)
def add_token(name: str, body: TokenCreate, who: Who, request: Request) -> dict[str, Any]:
    """A new API token (shown once): a user's own, or anyone's by an administrator."""
    if who.name != name:
        require(who, Grant.ADMINISTER)
    token, record = _people(request).add_token(name, body.label, body.days * 86400.0)
    return {**record, "token": token}


@router.delete("/tokens/{token_id}")
def revoke(token_id: int, who: Who, request: Request) -> dict[str, Any]:
    people = _people(request)
    if people.token(token_id)["user"] != who.name:
        require(who, Grant.ADMINISTER)
    return people.revoke(token_id)


@router.get("/audit")
def audit(_: Who, request: Request, after: Annotated[int, Query(ge=0)] = 0,
          limit: Annotated[int, Query(ge=1, le=1000)] = 200) -> list[dict[str, Any]]:
    return list(request.app.state.audit.records(limit=limit, after=after))


@router.get("/audit/check")
def audit_check(_: Who, request: Request) -> dict[str, Any]:
    """The chain checked: the first record whose link or hash is wrong, if any."""
    return dict(request.app.state.audit.check())
