"""The nightly history on S3: moto's S3 server on loopback (a process of its own) stands in
for the store. Each commit is a conditional put (If-None-Match), so nights appending at
once lose nothing, and a retried night adds nothing."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import textwrap
import time

import pytest
from conftest import skip_without

from enctools.report import historytable
from enctools.report.history import append_run, read_history

skip_without("moto")


@pytest.fixture(scope="module")
def s3():
    """An S3 server on 127.0.0.1 with the bucket ``lab``; the environment delta-rs reads."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p",
                               str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            break
        except OSError:
            assert time.monotonic() < deadline and server.poll() is None, "moto did not start"
            time.sleep(0.1)
    env = {"AWS_ENDPOINT_URL": f"http://127.0.0.1:{port}", "AWS_ACCESS_KEY_ID": "test",
           "AWS_SECRET_ACCESS_KEY": "test", "AWS_REGION": "us-east-1",
           "ENC_HISTORY_ALLOW_HTTP": "1"}
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update(env)
    import boto3
    boto3.client("s3", endpoint_url=env["AWS_ENDPOINT_URL"]).create_bucket(Bucket="lab")
    try:
        yield env
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        server.terminate()
        server.wait(timeout=30)


def test_commits_on_s3_are_conditional_puts(s3, monkeypatch):
    import boto3
    from botocore.exceptions import ClientError

    assert historytable.storage_options("s3://lab/h")["conditional_put"] == "etag"
    monkeypatch.setenv("AWS_S3_LOCKING_PROVIDER", "dynamodb")     # a lock instead
    assert "conditional_put" not in historytable.storage_options("s3://lab/h")
    monkeypatch.delenv("AWS_S3_LOCKING_PROVIDER")
    client = boto3.client("s3", endpoint_url=s3["AWS_ENDPOINT_URL"])
    client.put_object(Bucket="lab", Key="probe", Body=b"1")
    with pytest.raises(ClientError, match="PreconditionFailed"):  # the server holds to it
        client.put_object(Bucket="lab", Key="probe", Body=b"2", IfNoneMatch="*")


def test_a_history_on_s3_reads_back_and_a_retry_adds_nothing(s3):
    where = "s3://lab/one"
    night = {"rig": "0042", "status": "ok", "run_id": "n1", "pp": 1.0}
    assert append_run(where, night) == 1
    assert append_run(where, night) == 0
    assert append_run(where, {"rig": "Prüfstand ü", "status": "ok", "pp": 2.0}) == 1
    h = read_history(where)
    assert h.runs == 2 and sorted(h.column("rig").tolist()) == ["0042", "Prüfstand ü"]
    assert read_history(where, rig="0042").column("pp").tolist() == [1.0]
    table = historytable.open_table(where)
    assert historytable.schema_version(table) == historytable.SCHEMA_VERSION


_WRITERS = textwrap.dedent("""
    import sys
    from enctools.report.history import append_run
    for i in range(2):
        append_run(sys.argv[1], {"rig": "w" + sys.argv[2], "status": "ok",
                                 "run_id": f"p{sys.argv[2]}-{i}"})
""")


@pytest.mark.slow
def test_nights_appending_to_s3_at_once_lose_nothing(s3):
    where = "s3://lab/fleet"
    append_run(where, {"rig": "first", "status": "ok"})   # the table made
    env = dict(os.environ, **s3)
    procs = [subprocess.Popen([sys.executable, "-c", _WRITERS, where, str(k)], env=env,
                              stderr=subprocess.PIPE) for k in range(8)]
    errs = [p.communicate(timeout=600)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * 8, errs
    h = read_history(where)
    assert h.runs == 17 and len(set(h.column("run_id"))) == 17
