"""Who a request is, and whether their role has the grant its route needs (`service/roles.py`).

A bearer token is a user's API token (its digest looked up in the database on every request: a
revocation or a role change holds at once on every service of the database), or, for one
release, the old shared `SCREWCAL_TOKEN` (an administrator, with a deprecation warning in the
log) or `read_token` (a viewer). Tokens are compared in constant time and never logged. The
grant is the route's, from the one table `roles.ROUTES`: a route missing from it is refused.
"""

from __future__ import annotations

import logging
import secrets
from typing import Annotated

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from service.people import Principal
from service.roles import GRANT_OF, Grant, Role, may

BEARER = HTTPBearer(auto_error=False, description="a user's API token (`screwcal user token`), "
                    "or the token `POST /session` gives")
LOG = logging.getLogger("screwcal.service.auth")
_warned: set[str] = set()


def _legacy(request: Request, token: str) -> Principal | None:
    settings = request.app.state.settings
    for shared, name, role in ((settings.token, "SCREWCAL_TOKEN", Role.ADMINISTRATOR),
                               (settings.read_token, "read token", Role.VIEWER)):
        if shared and secrets.compare_digest(token.encode(), shared.encode()):
            if name not in _warned:
                _warned.add(name)
                LOG.warning("the shared %s is deprecated: it acts as one %s that nobody is "
                            "named as; give people their own users (`screwcal user add`)",
                            name, role.value)
            return Principal(name, role, legacy=True)
    return None


def principal_of(request: Request,
                 credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(BEARER)]
                 ) -> Principal:
    """The request's principal (401 without a bearer token, 403 with one nobody has)."""
    if credentials is None or credentials.scheme.lower() != "bearer":
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, "bearer token required",
                            headers={"WWW-Authenticate": "Bearer"})
    token = credentials.credentials
    principal = _legacy(request, token) or request.app.state.people.principal(token)
    if principal is None:
        raise HTTPException(status.HTTP_403_FORBIDDEN, "token refused (unknown, revoked or "
                            "expired)")
    request.state.principal = principal
    return principal


def require(principal: Principal, grant: Grant) -> None:
    """403 unless the principal's role has `grant`."""
    if not may(principal.role, grant):
        raise HTTPException(status.HTTP_403_FORBIDDEN, f"{principal.name} ({principal.role}) "
                            f"lacks the grant '{grant}'")


def authorised(request: Request, principal: Annotated[Principal, Depends(principal_of)]
               ) -> Principal:
    """The principal, having the grant the route declares in `roles.ROUTES`."""
    route = request.scope.get("route")
    key = (request.method, getattr(route, "path", ""))
    if key not in GRANT_OF:
        raise HTTPException(status.HTTP_403_FORBIDDEN, f"{key[0]} {key[1]} declares no grant")
    grant = GRANT_OF[key]
    if grant is not None:
        require(principal, grant)
    return principal


Who = Annotated[Principal, Depends(authorised)]
