"""The audit trail: every change, every action that moves or changes a robot and every refused
attempt, with who, when (the database's clock), from where, what and the outcome; append only,
and tamper-evident.

Each record carries the SHA-256 of the one before it and its own (over its fields and that
link), so editing or deleting a record breaks the chain at that record, and `check` names the
first broken link; the head (the last record's id and hash, written in the same transaction)
shows records cut from the end. `check` returns the head's hash: written down elsewhere (a
shift log, another system), it also shows a chain rewritten whole. Two services appending at
once cannot both take the same predecessor: the link column is unique, and the loser takes the
new last record and tries again.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Any

from service.database import Database

GENESIS = "0" * 64  # the link of the first record
_RETRIES = 8


@dataclass(frozen=True)
class Event:
    actor: str  # a user's name, or "anonymous", or "token:<first 4 characters>"
    source: str  # the client's address
    action: str  # "POST /jobs", "sign-in"...
    target: str  # what it acted on ("job 12", "user ana")
    outcome: str  # "200", "403 refused: ...", "signed in"
    detail: str = ""


def _digest(prev: str, at: float, e: Event) -> str:
    body = json.dumps([prev, repr(at), e.actor, e.source, e.action, e.target, e.outcome,
                       e.detail], separators=(",", ":"))
    return hashlib.sha256(body.encode()).hexdigest()


def record(db: Database, event: Event) -> int:
    """Append `event` inside the caller's transaction (`db.tx()`): it stands or falls with the
    change it records. A unique-link conflict (another service appended first) raises the
    database's integrity error; the caller tries again."""
    last = db.execute("SELECT hash FROM audit ORDER BY id DESC LIMIT 1").fetchone()
    prev = last["hash"] if last else GENESIS
    at = float(db.execute(f"SELECT {db.now_sql} AS t").fetchone()["t"])
    digest = _digest(prev, at, event)
    row = db.execute(
        "INSERT INTO audit (at, actor, source, action, target, outcome, detail, prev, hash) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
        (at, event.actor[:80], event.source[:80], event.action[:120], event.target[:120],
         event.outcome[:200], event.detail[:500], prev, digest)).fetchone()
    db.execute("UPDATE audit_head SET last_id = ?, last_hash = ? WHERE one = 1",
               (row["id"], digest))
    return int(row["id"])


class AuditTrail:
    def __init__(self, db: Database) -> None:
        self.db = db

    def append(self, event: Event) -> int:
        """Record an event at the database's time, in a transaction of its own; its id."""
        for _ in range(_RETRIES):
            try:
                with self.db.tx() as db:
                    return record(db, event)
            except self.db.integrity_errors:
                continue  # another service appended the same predecessor's successor first
        raise RuntimeError("the audit trail stayed busy: too many services appending at once")

    def records(self, limit: int = 200, after: int = 0) -> list[dict[str, Any]]:
        return self.db.rows("SELECT id, at, actor, source, action, target, outcome, detail, "
                            "prev, hash FROM audit WHERE id > ? ORDER BY id LIMIT ?",
                            (after, limit))

    def check(self) -> dict[str, Any]:
        """The chain checked from the first record: {'ok', 'records', 'first_broken', 'why',
        'head'}."""
        prev, count, after = GENESIS, 0, 0
        head = self.db.row("SELECT last_id, last_hash FROM audit_head WHERE one = 1") or \
            {"last_id": 0, "last_hash": GENESIS}
        while True:
            rows = self.records(limit=1000, after=after)
            if not rows:
                if (after, prev) != (head["last_id"], head["last_hash"]):
                    return {"ok": False, "records": count, "first_broken": after + 1,
                            "why": f"the trail ends at record {after} but its head names "
                                   f"record {head['last_id']}: records were cut from its end",
                            "head": head["last_hash"]}
                return {"ok": True, "records": count, "first_broken": None, "why": "",
                        "head": prev}
            for r in rows:
                event = Event(r["actor"], r["source"], r["action"], r["target"], r["outcome"],
                              r["detail"])
                if r["prev"] != prev:
                    return {"ok": False, "records": count, "first_broken": r["id"],
                            "why": "its link does not name the record before it (a record "
                                   "before it was deleted or changed)", "head": None}
                if r["hash"] != _digest(prev, float(r["at"]), event):
                    return {"ok": False, "records": count, "first_broken": r["id"],
                            "why": "its fields do not give its hash (the record was changed)",
                            "head": None}
                prev, count, after = r["hash"], count + 1, r["id"]
