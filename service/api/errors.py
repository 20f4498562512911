"""The HTTP status of each service error (service/errors.py draws the tree), and of a refused
request body."""

from __future__ import annotations

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

from service.errors import (
    AccountError,
    ConflictError,
    CredentialsError,
    NotFoundError,
    SafetyError,
    ServiceError,
    StoreError,
    StoreLostError,
)

HTTP_STATUS: dict[type[ServiceError], int] = {
    NotFoundError: 404,
    ConflictError: 409,
    SafetyError: 422,
    AccountError: 422,
    CredentialsError: 401,
    StoreError: 503,  # a lost database also stops the service
}


async def service_error(request: Request, err: Exception) -> JSONResponse:
    """A service error as its status and its message."""
    if isinstance(err, StoreLostError):
        request.app.state.manager.fatal(str(err))
    code = next(code for kind, code in HTTP_STATUS.items() if isinstance(err, kind))
    return JSONResponse({"detail": str(err)}, status_code=code)


async def invalid_request(_: Request, err: Exception) -> JSONResponse:
    """Every refused request gets its reasons, even when its input cannot be echoed back
    (a NaN is not JSON): where and what, never the value."""
    assert isinstance(err, RequestValidationError)
    detail = [{"loc": list(e.get("loc", ())), "msg": str(e.get("msg", "")),
               "type": str(e.get("type", ""))} for e in err.errors()]
    return JSONResponse({"detail": detail}, status_code=422)


def install_error_handlers(app: FastAPI) -> None:
    for kind in HTTP_STATUS:
        app.add_exception_handler(kind, service_error)
    app.add_exception_handler(RequestValidationError, invalid_request)
