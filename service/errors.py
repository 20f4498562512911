"""The exception tree of the service.

    ServiceError
    ├── NotFoundError      no such robot or job (HTTP 404)
    ├── ConflictError      the request does not fit the job's state (HTTP 409)
    └── SafetyError        a target or correction refused before anything is sent (HTTP 422)
"""


class ServiceError(Exception):
    """Base of every error the service raises on purpose."""


class NotFoundError(ServiceError):
    pass


class ConflictError(ServiceError):
    pass


class SafetyError(ServiceError):
    pass
