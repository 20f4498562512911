"""People across services and over the wire: two services on one PostgreSQL see a revocation
and a role change at once; a real `screwcal serve` over HTTPS with its first administrator,
signed in and driven by `screwcal user` and `screwcal audit` as processes."""

import os
import shutil
import subprocess
import sys
import time

import httpx
import pytest

from service.app import create_app
from service.roles import Role
from service.server import check_transport
from service.settings import ServiceSettings

PASSWORD = "correct horse battery"


async def test_two_services_on_one_postgresql_refuse_a_revoked_token_at_once(postgres_server):
    url = postgres_server.new_database()
    one = create_app(ServiceSettings(db_url=url, instance="one"))
    two = create_app(ServiceSettings(db_url=url, instance="two"))
    async with one.router.lifespan_context(one), two.router.lifespan_context(two):
        one.state.people.add_user("ana", Role.ENGINEER, PASSWORD)
        token, record = one.state.people.add_token("ana", "laptop", 3600.0)
        auth = {"Authorization": f"Bearer {token}"}
        async with httpx.AsyncClient(transport=httpx.ASGITransport(app=two),
                                     base_url="http://two") as http:
            assert (await http.get("/jobs", headers=auth)).status_code == 200
            one.state.people.set_role("ana", Role.VIEWER)  # on the other service
            assert (await http.post("/robots", headers=auth, json={})).status_code == 403
            one.state.people.revoke(record["id"])
            start = time.monotonic()
            assert (await http.get("/jobs", headers=auth)).status_code == 403
            assert time.monotonic() - start < 1.0  # the next request: no cache to expire
        assert two.state.audit.check()["ok"]  # both services appended to one chain


def test_beyond_loopback_needs_tls_or_saying_so(tmp_path):
    with pytest.raises(Exception, match="without TLS"):
        check_transport(ServiceSettings(host="0.0.0.0"))
    check_transport(ServiceSettings(host="0.0.0.0", insecure_http=True))
    with pytest.raises(Exception, match="both --tls-cert and --tls-key"):
        check_transport(ServiceSettings(tls_cert=tmp_path / "c.pem"))


@pytest.mark.skipif(shutil.which("openssl") is None, reason="no openssl to make a certificate")
def test_a_tls_service_bootstrapped_and_driven_from_the_command_line(tmp_path):
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1",
                    "-subj", "/CN=localhost", "-addext", "subjectAltName=IP:127.0.0.1",
                    "-keyout", str(key), "-out", str(cert)], check=True, capture_output=True)
    env = {**os.environ, "SCREWCAL_ADMIN_PASSWORD": PASSWORD, "SCREWCAL_PASSWORD": PASSWORD}
    env.pop("SCREWCAL_TOKEN", None)
    with subprocess.Popen(
            [sys.executable, "-m", "screwcal", "serve", "--db", str(tmp_path / "s.db"), "--port",
             "0", "--admin", "root-admin", "--tls-cert", str(cert), "--tls-key", str(key)],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) as serve:
        _drive(serve, cert, env)


def _drive(serve: subprocess.Popen, cert, env) -> None:
    try:
        line = serve.stdout.readline()
        assert line.startswith("screwcal service on https://127.0.0.1:"), line
        url = line.split()[3]

        def cli(*args, token=None):
            return subprocess.run([sys.executable, "-m", "screwcal", *args, "--service", url,
                                   "--ca-cert", str(cert), *(["--token", token] if token
                                                             else [])],
                                  env=env, capture_output=True, text=True, timeout=60)

        signed = cli("user", "sign-in", "root-admin")
        assert signed.returncode == 0, signed.stderr
        admin = signed.stdout.strip()
        assert cli("user", "add", "ana", "--role", "operator", token=admin).returncode == 0
        listed = cli("user", "list", token=admin)
        assert "ana" in listed.stdout and "operator" in listed.stdout
        ana = cli("user", "sign-in", "ana").stdout.strip()
        refused = cli("user", "list", token=ana)
        assert refused.returncode != 0 and "lacks the grant 'administer'" in refused.stderr
        audit = cli("audit", "--check", token=admin)
        assert audit.returncode == 0 and "audit trail intact" in audit.stdout
    finally:
        serve.terminate()
        serve.wait(timeout=30)
