"""Users, their roles and their API tokens, in the job store's database.

Read on every request, never cached: a token revoked or a role changed on one service is in
force at once on every service of the same database. A password is kept as its argon2id hash, a
token as its SHA-256 (`credentials`); neither is ever logged nor put in a URL.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from service.credentials import hash_password, new_token, password_matches, token_digest
from service.database import Database
from service.errors import AccountError, ConflictError, CredentialsError, NotFoundError
from service.roles import Role

NAME = re.compile(r"[A-Za-z0-9_.@-]{1,64}")
MIN_PASSWORD = 12  # characters
SESSION_S = 8 * 3600.0  # a sign-in's token lives a shift


@dataclass(frozen=True)
class Principal:
    """Who makes a request: a user and the role they have now (or a legacy shared token)."""

    name: str
    role: Role
    token_id: int | None = None
    legacy: bool = False


class People:
    def __init__(self, db: Database) -> None:
        self.db = db

    # -- users ---------------------------------------------------------------------------------
    def add_user(self, name: str, role: Role, password: str) -> dict[str, Any]:
        if not NAME.fullmatch(name):
            raise AccountError(f"user name {name!r}: 1 to 64 letters, digits or _ . @ -")
        if len(password) < MIN_PASSWORD:
            raise AccountError(f"a password has at least {MIN_PASSWORD} characters")
        digest = hash_password(password)
        with self.db.tx() as db:
            if db.execute("SELECT id FROM users WHERE name = ?", (name,)).fetchone():
                raise ConflictError(f"user {name!r} exists")
            db.execute(f"INSERT INTO users (name, role, password_hash, created, disabled) "
                       f"VALUES (?, ?, ?, {db.now_sql}, 0)", (name, role.value, digest))
        return self.user(name)

    def user(self, name: str) -> dict[str, Any]:
        row = self.db.row("SELECT id, name, role, created, disabled FROM users WHERE name = ?",
                          (name,))
        if row is None:
            raise NotFoundError(f"no user {name!r}")
        return row

    def users(self) -> list[dict[str, Any]]:
        return self.db.rows("SELECT id, name, role, created, disabled FROM users ORDER BY id")

    def count(self) -> int:
        row = self.db.row("SELECT COUNT(*) AS n FROM users")
        return int(row["n"]) if row else 0

    def set_role(self, name: str, role: Role) -> dict[str, Any]:
        with self.db.tx() as db:
            done = db.execute("UPDATE users SET role = ? WHERE name = ?", (role.value, name))
            if done.rowcount == 0:
                raise NotFoundError(f"no user {name!r}")
        return self.user(name)

    def check_password(self, name: str, password: str) -> Principal:
        row = self.db.row("SELECT name, role, password_hash, disabled FROM users WHERE name = ?",
                          (name,))
        if row is None or row["disabled"] or not password_matches(row["password_hash"],
                                                                  password):
            raise CredentialsError("name or password refused")
        return Principal(row["name"], Role(row["role"]))

    # -- tokens --------------------------------------------------------------------------------
    def add_token(self, name: str, label: str, lifetime_s: float) -> tuple[str, dict[str, Any]]:
        """A new token of user `name`: the token (shown once) and its record."""
        user = self.user(name)
        token = new_token()
        with self.db.tx() as db:
            row = db.execute(
                f"INSERT INTO api_tokens (user_id, label, digest, created, expires, revoked) "
                f"VALUES (?, ?, ?, {db.now_sql}, {db.now_sql} + ?, 0) RETURNING id",
                (user["id"], label[:80], token_digest(token), lifetime_s)).fetchone()
        return token, self.token(int(row["id"]))

    def token(self, token_id: int) -> dict[str, Any]:
        row = self.db.row("SELECT t.id, u.name AS user, t.label, t.created, t.expires, "
                          "t.revoked FROM api_tokens t JOIN users u ON u.id = t.user_id "
                          "WHERE t.id = ?", (token_id,))
        if row is None:
            raise NotFoundError(f"no token {token_id}")
        return row

    def tokens(self, name: str) -> list[dict[str, Any]]:
        return self.db.rows("SELECT t.id, u.name AS user, t.label, t.created, t.expires, "
                            "t.revoked FROM api_tokens t JOIN users u ON u.id = t.user_id "
                            "WHERE u.name = ? ORDER BY t.id", (name,))

    def revoke(self, token_id: int) -> dict[str, Any]:
        with self.db.tx() as db:
            done = db.execute("UPDATE api_tokens SET revoked = 1 WHERE id = ?", (token_id,))
            if done.rowcount == 0:
                raise NotFoundError(f"no token {token_id}")
        return self.token(token_id)

    def principal(self, token: str) -> Principal | None:
        """Who a bearer token is, on the database's clock: None when it is unknown, revoked,
        expired, or its user disabled."""
        row = self.db.row(
            f"SELECT u.name, u.role, t.id FROM api_tokens t JOIN users u ON u.id = t.user_id "
            f"WHERE t.digest = ? AND t.revoked = 0 AND u.disabled = 0 "
            f"AND t.expires > {self.db.now_sql}", (token_digest(token),))
        if row is None:
            return None
        return Principal(row["name"], Role(row["role"]), token_id=int(row["id"]))

