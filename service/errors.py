"""The exception tree of the service.

    ServiceError
    ├── NotFoundError      no such robot or job (HTTP 404)
    ├── ConflictError      the request does not fit the job's state (HTTP 409)
    │   └── LeaseLostError     another service holds the job now (its lease expired here)
    ├── SafetyError        a target or correction refused before anything is sent (HTTP 422)
    ├── AccountError       a user name or password that breaks the rules (HTTP 422)
    ├── CredentialsError   a name and password that do not sign in (HTTP 401; never says which)
    └── StoreError         the database cannot be used (HTTP 503)
        ├── StoreBusyError     another live service holds the database file
        ├── StoreUnavailableError  the database cannot be written for now (an I/O error, a
        │   │                  file-size limit, a read-only file, a lost PostgreSQL
        │   │                  connection): jobs pause and go on when it is back
        │   └── StoreFullError     the disk (or the database's size limit) is full
        ├── StoreLostError     the database file was deleted or replaced under the service
        └── SchemaTooNewError  a newer release wrote the database: this one must not
"""


class ServiceError(Exception):
    """Base of every error the service raises on purpose."""


class NotFoundError(ServiceError):
    pass


class ConflictError(ServiceError):
    pass


class LeaseLostError(ConflictError):
    """This service no longer holds the job: a runner that gets this changes nothing more."""


class SafetyError(ServiceError):
    pass


class StoreError(ServiceError):
    """The job store cannot be used: nothing can be committed."""


class StoreBusyError(StoreError):
    pass


class StoreUnavailableError(StoreError):
    """For now: what was not committed is done again once the database is back (the store
    reconnects by itself), and nothing committed is lost."""


class StoreFullError(StoreUnavailableError):
    pass


class StoreLostError(StoreError):
    pass


class SchemaTooNewError(StoreError):
    pass


class AccountError(ServiceError):
    """A user name or a password that breaks the rules (length, characters)."""


class CredentialsError(ServiceError):
    """A name, password or token that does not sign in (the message never says which)."""
