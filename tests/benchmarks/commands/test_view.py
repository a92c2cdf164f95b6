"""Tests of ``bnerr view``: a results folder served on localhost."""

import threading
import urllib.request

import pytest

from benchmarks.cli import main
from benchmarks.commands.view import make_server
from bnerr.errors import ValueRangeError


def test_serves_the_folder_and_its_pages(tmp_path):
    (tmp_path / "index.html").write_text("<p>hello</p>")
    server = make_server(tmp_path, port=0)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        host, port = server.server_address[:2]
        with urllib.request.urlopen(f"http://{host}:{port}/index.html", timeout=5) as response:
            assert response.read() == b"<p>hello</p>"
    finally:
        server.shutdown()
        server.server_close()
        thread.join(5)


def test_a_folder_without_a_page_is_refused(tmp_path):
    with pytest.raises(ValueRangeError, match="index.html"):
        make_server(tmp_path, port=0)
    with pytest.raises(ValueRangeError, match="no folder"):
        make_server(tmp_path / "missing", port=0)


def test_the_command_refuses_in_one_line(tmp_path, capsys):
    assert main(["view", str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bnerr view: error: ") and err.count("\n") == 1
    assert main(["view", str(tmp_path), "--port", "70000"]) == 2


def test_the_command_prints_its_address(tmp_path, capsys, monkeypatch):
    (tmp_path / "index.html").write_text("x")
    monkeypatch.setattr("http.server.ThreadingHTTPServer.serve_forever", lambda self: None)
    assert main(["view", str(tmp_path), "--port", "0"]) == 0
    assert "at http://127.0.0.1:" in capsys.readouterr().out
