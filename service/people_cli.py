"""`screwcal user ...` and `screwcal audit`: people and the audit trail, through the service's
API (an administrator's token; a user may make and revoke their own tokens).

    screwcal user add NAME --role viewer|operator|engineer|instrument|administrator
    screwcal user list
    screwcal user role NAME ROLE
    screwcal user token NAME [--label L] [--lifetime-s S]   # prints the token once
    screwcal user revoke TOKEN_ID
    screwcal user sign-in NAME                          # a token of one shift (8 h)
    screwcal audit [--after ID] [--check]

The password of `add` and `sign-in` is read from SCREWCAL_PASSWORD or asked for (never an
argument: it would stay in the shell's history and the process list).
"""

from __future__ import annotations

import argparse
import getpass
import json
import os
import sys
from typing import Any

from service.errors import ServiceError
from service.roles import Role


def _password(args: argparse.Namespace) -> str:
    password = os.environ.get("SCREWCAL_PASSWORD")
    if password is None:
        if not sys.stdin.isatty():
            raise ServiceError("no password: set SCREWCAL_PASSWORD or run in a terminal")
        password = getpass.getpass(f"password for {args.name}: ")
    return password


def _client(args: argparse.Namespace, token: bool = True) -> Any:
    import httpx

    headers = {}
    if token:
        value = args.token or os.environ.get("SCREWCAL_TOKEN", "")
        if not value:
            raise ServiceError("no token: pass --token or set SCREWCAL_TOKEN (an "
                               "administrator's, from `screwcal user token` or `user sign-in`)")
        headers["Authorization"] = f"Bearer {value}"
    url = args.service or os.environ.get("SCREWCAL_SERVICE", "http://127.0.0.1:8080")
    verify: Any = args.ca_cert or True
    return httpx.Client(base_url=url, headers=headers, timeout=30.0, verify=verify)


def _call(args: argparse.Namespace, method: str, path: str, body: dict | None = None,
          token: bool = True) -> Any:
    import httpx

    with _client(args, token) as http:
        try:
            r = http.request(method, path, json=body)
        except httpx.TransportError as err:
            raise ServiceError(f"cannot reach the service at {http.base_url} ({err}): is "
                               "`screwcal serve` running there?") from None
    if r.status_code >= 400:
        try:
            detail = r.json().get("detail")
        except ValueError:
            detail = r.text
        raise ServiceError(f"{method} {path}: {r.status_code} {detail}")
    return r.json() if r.content else None


def bootstrap_administrator(settings: Any, name: str) -> None:
    """The first administrator, when the database has no user: `screwcal serve --admin NAME`."""
    from service.people import People
    from service.store import open_store

    store = open_store(settings)
    try:
        people = People(store.db)
        if people.count():
            print(f"users exist already: --admin {name} ignored", file=sys.stderr)
            return
        password = os.environ.get("SCREWCAL_ADMIN_PASSWORD")
        if password is None:
            if not sys.stdin.isatty():
                raise ServiceError("the first administrator needs a password: set "
                                   "SCREWCAL_ADMIN_PASSWORD or run in a terminal")
            password = getpass.getpass(f"password for the administrator {name}: ")
        people.add_user(name, Role.ADMINISTRATOR, password)
        print(f"administrator {name} made; sign in with `screwcal user sign-in {name}`",
              file=sys.stderr)
    finally:
        store.close()


def run_user(args: argparse.Namespace) -> int:
    a = args.action
    if a == "add":
        out = _call(args, "POST", "/users", {"name": args.name, "role": args.role,
                                             "password": _password(args)})
    elif a == "list":
        for u in _call(args, "GET", "/users"):
            print(f"{u['name']:24s} {u['role']:14s}{' (disabled)' if u['disabled'] else ''}")
        return 0
    elif a == "role":
        out = _call(args, "PUT", f"/users/{args.name}/role", {"role": args.role})
    elif a == "token":
        out = _call(args, "POST", f"/users/{args.name}/tokens",
                    {"label": args.label, "days": args.lifetime_s / 86400.0})
        print(out["token"])
        print(f"token {out['id']} of {out['user']}: shown once, keep it as a secret",
              file=sys.stderr)
        return 0
    elif a == "revoke":
        out = _call(args, "DELETE", f"/tokens/{args.token_id}")
    else:  # sign-in
        out = _call(args, "POST", "/session", {"name": args.name, "password": _password(args)},
                    token=False)
        print(out["token"])
        print(f"signed in as {args.name} ({out['role']}) for 8 h", file=sys.stderr)
        return 0
    print(json.dumps(out, indent=1))
    return 0


def run_audit(args: argparse.Namespace) -> int:
    if args.check:
        out = _call(args, "GET", "/audit/check")
        if out["ok"]:
            print(f"audit trail intact: {out['records']} records chained")
            return 0
        print(f"audit trail BROKEN at record {out['first_broken']}: {out['why']}")
        return 1
    for r in _call(args, "GET", f"/audit?after={args.after}&limit=1000"):
        print(f"{r['id']:6d} {r['at']:.3f} {r['actor']:16s} {r['source']:15s} "
              f"{r['action']:32s} {r['target']:16s} {r['outcome']}")
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--service", default=None, help="service URL (or SCREWCAL_SERVICE)")
    common.add_argument("--token", default=None, help="bearer token (or SCREWCAL_TOKEN)")
    common.add_argument("--ca-cert", default=None, help="the CA certificate a TLS service's "
                        "certificate is checked against (default: the system's)")
    u = sub.add_parser("user", help="people: users, roles, tokens (an administrator's)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = u.add_subparsers(dest="action", metavar="ACTION", required=True)
    roles = [r.value for r in Role]
    p = actions.add_parser("add", parents=[common], help="a new user")
    p.add_argument("name", help="the user's name (letters, digits, _ . @ -)")
    p.add_argument("--role", required=True, choices=roles, help="what they may do "
                   "(docs/service.md: the grants of each role)")
    actions.add_parser("list", parents=[common], help="the users and their roles")
    p = actions.add_parser("role", parents=[common], help="change a user's role")
    p.add_argument("name", help="the user")
    p.add_argument("role", choices=roles, help="the new role: in force at their next request")
    p = actions.add_parser("token", parents=[common], help="a new API token (printed once)")
    p.add_argument("name", help="whose token (one's own, or anyone's for an administrator)")
    p.add_argument("--label", default="", help="what it is for")
    p.add_argument("--lifetime-s", type=float, default=90 * 86400.0, help="how long it lives "
                   "(default 90 days)")
    p = actions.add_parser("revoke", parents=[common], help="revoke a token at once")
    p.add_argument("token_id", type=int, help="the token's id (`user token` prints it)")
    p = actions.add_parser("sign-in", parents=[common], help="a token of one shift")
    p.add_argument("name", help="who signs in")
    u.set_defaults(func=run_user)
    a = sub.add_parser("audit", parents=[common], help="the audit trail (administrators)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("--after", type=int, default=0, help="records after this id")  # an id
    a.add_argument("--check", action="store_true", help="check the chain: exit 1 and the "
                   "first broken record when one was edited or deleted")
    a.set_defaults(func=run_audit)
