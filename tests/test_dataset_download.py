"""Dataset downloads through pooch (issue 29): a local HTTP server stands in for the
official source. Plain and gzip files, the sha256 of the stored file, retries after a
server error and after a bad hash, and nothing left in the cache when a download is
refused."""

from __future__ import annotations

import gzip
import hashlib
import http.server
import threading
from pathlib import Path

import pytest

from pipeline.errors import UserError
from pipeline.io import datasets

DATA = b"0 6.0 20.1\n2 9.0 20.3\n4 9.0 21.0\n"


class _Handler(http.server.BaseHTTPRequestHandler):
    files: dict[str, bytes] = {}
    failures: dict[str, int] = {}  # path -> server errors still to give before serving
    hits: dict[str, int] = {}

    def do_GET(self):  # noqa: N802 (the http.server API)
        self.hits[self.path] = self.hits.get(self.path, 0) + 1
        if self.failures.get(self.path, 0) > 0:
            self.failures[self.path] -= 1
            self.send_error(503)
            return
        body = self.files.get(self.path)
        if body is None:
            self.send_error(404)
            return
        self.send_response(200)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args):
        pass


@pytest.fixture
def server():
    _Handler.files, _Handler.failures, _Handler.hits = {}, {}, {}
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()
    httpd.server_close()


def _registry(tmp_path: Path, monkeypatch, url: str, *, gz: bool, sha: str | None = None):
    reg = tmp_path / "registry.yaml"
    reg.write_text(
        "plate:\n"
        "  title: a test log\n"
        f"  url: {url}\n"
        "  file: plate.dat\n"
        f"  sha256: {sha or hashlib.sha256(DATA).hexdigest()}\n"
        "  format: dat\n  input: u\n  output: y\n"
        + ("  compression: gzip\n" if gz else ""))
    monkeypatch.setenv(datasets.REGISTRY_ENV, str(reg))
    monkeypatch.setenv(datasets.CACHE_ENV, str(tmp_path / "cache"))
    monkeypatch.delenv(datasets.MIRROR_ENV, raising=False)
    return tmp_path / "cache" / "plate"


@pytest.mark.parametrize("gz", [False, True])
def test_download_checks_the_stored_file_and_fills_the_cache(tmp_path, monkeypatch, server, gz):
    name = "/data/plate.dat" + (".gz" if gz else "")
    _Handler.files[name] = gzip.compress(DATA) if gz else DATA
    cache = _registry(tmp_path, monkeypatch, server + name, gz=gz)
    p = datasets.fetch("plate")
    assert p == cache / "plate.dat" and p.read_bytes() == DATA
    assert sorted(x.name for x in cache.iterdir()) == ["plate.dat"]  # no staging, no .gz
    assert datasets.fetch("plate") == p and _Handler.hits[name] == 1  # the cache serves it


def test_a_server_error_is_retried(tmp_path, monkeypatch, server):
    monkeypatch.setattr(datasets, "RETRY_WAIT", 0.0)
    _Handler.files["/plate.dat"] = DATA
    _Handler.failures["/plate.dat"] = 1
    _registry(tmp_path, monkeypatch, server + "/plate.dat", gz=False)
    assert datasets.fetch("plate").read_bytes() == DATA
    assert _Handler.hits["/plate.dat"] == 2


@pytest.mark.parametrize("gz", [False, True])
def test_a_wrong_hash_is_refused_and_nothing_is_cached(tmp_path, monkeypatch, server, gz):
    name = "/plate.dat" + (".gz" if gz else "")
    _Handler.files[name] = gzip.compress(DATA) if gz else DATA
    cache = _registry(tmp_path, monkeypatch, server + name, gz=gz, sha="0" * 64)
    monkeypatch.setattr(datasets, "RETRIES", 0)
    with pytest.raises(UserError) as exc:
        datasets.fetch("plate")
    assert server + name in exc.value.message and "PIPELINE_DATASETS_MIRROR" in exc.value.message
    assert not cache.exists() or list(cache.iterdir()) == []


def test_a_missing_file_says_where_it_looked(tmp_path, monkeypatch, server):
    _registry(tmp_path, monkeypatch, server + "/gone.dat", gz=False)
    monkeypatch.setattr(datasets, "RETRIES", 0)
    with pytest.raises(UserError, match="404"):
        datasets.fetch("plate")


@pytest.mark.parametrize("gz", [False, True])
def test_a_bad_hash_is_tried_again_then_refused(tmp_path, monkeypatch, server, gz):
    """The hash of the stored file is checked after decompression too: a gzip entry whose
    file does not match is fetched RETRIES + 1 times, as a plain one is."""
    monkeypatch.setattr(datasets, "RETRY_WAIT", 0.0)
    name = "/plate.dat" + (".gz" if gz else "")
    _Handler.files[name] = gzip.compress(DATA) if gz else DATA
    _registry(tmp_path, monkeypatch, server + name, gz=gz, sha="0" * 64)
    with pytest.raises(UserError):
        datasets.fetch("plate")
    assert _Handler.hits[name] == datasets.RETRIES + 1


def test_an_unknown_scheme_is_one_line(tmp_path, monkeypatch):
    _registry(tmp_path, monkeypatch, "gopher://example.org/plate.dat", gz=False)
    monkeypatch.setattr(datasets, "RETRY_WAIT", 60.0)  # not tried again: no wait
    with pytest.raises(UserError, match="unsupported URL scheme 'gopher'"):
        datasets.fetch("plate")
