"""report.html: everything the safety assessor needs on one self-contained page, rendered
in a real headless browser that fetches nothing from the network.

The browser test needs Chromium (Debian: ``apt-get install chromium``; ``.ci/run``
installs it where it can) and is skipped, saying so, where there is none. The page's own
requests are read from the browser over the DevTools protocol (the browser's background
traffic is not the page's), and every http(s) request goes to a local proxy that answers
404, so nothing leaves the machine; a page with an external style sheet and image shows
that the watch sees what a page fetches."""

import http.server
import json
import os
import queue
import re
import shutil
import subprocess
import threading
import time
from pathlib import Path

import pytest

from verification.deploy.certificate import read_certificate

CHROMIUM = next((shutil.which(name) for name in ("chromium", "chromium-browser",
                                                 "google-chrome") if shutil.which(name)), None)
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium on PATH: the report.html browser test needs a "
                             "real headless browser (Debian: apt-get install -y chromium; "
                             ".ci/run installs it when it runs as root)")
SECTIONS = ["1. The cell", "2. The configuration", "3. The verdict and its premises",
            "4. The scenario space", "5. Counterexamples found on the way", "6. Robustness",
            "7. Checksum", "8. Sign-off"]


def _html(folder: Path) -> str:
    return (folder / "export" / "report.html").read_text()


def test_the_page_holds_what_the_assessor_needs(exported):
    page = _html(exported)
    cert, _ = read_certificate(exported / "export" / "certificate.json")
    for section in SECTIONS:
        assert f"<h2>{section}</h2>" in page, section
    assert cert["checksum"] in page and cert["checksum_short"] in page
    assert "PROVED" in page and "PLACEHOLDER" in page
    for premise in cert["premises"]:  # each premise in words, checked or trusted
        assert premise["statement"].replace("&", "&amp;").replace("<", "&lt;") \
            .replace(">", "&gt;").replace('"', "&quot;").replace("'", "&#x27;") in page
    assert "ISO/TS 15066:2016" in page and "ISO 13855:2010" in page
    assert "<code>safety.reaction_time</code>" in page and ">T_r<" in page
    assert "<code>safety.robot_speed</code>" in page and "v_R (S_R = v_R T_r)" in page
    # The whole cell in words: the capsules, the operators' body model and what is
    # tracked, hidden bodies, the gate.
    for words in ("robot as the monitor measures it", "whole bodies as capsules",
                  "forearm 0.41 m", "tracked at: hand_right, hand_left, head",
                  "a ball growing at 2 m/s", "gated: a frame farther",
                  "none declared: in the live cell a person who walks out of the cameras"):
        assert words in page, words
    for name in ("contact", "separation"):  # both properties' verdicts
        assert f'<h3>{name}: <span class="proved">proved</span></h3>' in page
    assert page.count('<tr><td>') >= 3 and re.search(
        r"<tr><td>Safety assessor</td>(<td></td>){4}</tr>", page)  # empty sign-off fields
    assert "data:image/png;base64," in page  # the robustness figure, inline


def test_no_exits_says_what_that_means_for_a_live_cell():
    from safety_systems.config.scenario import Box, TrackerConfig
    from verification.deploy.assessor_report import exits_words

    words = exits_words(TrackerConfig(), 2.0)
    assert words.startswith("none declared: in the live cell a person who walks out of the "
                            "cameras' view stays a hazard, a ball growing at 2 m/s")
    assert "the robot slows and then stands still" in words and "tracker.exits" in words
    assert "walls" not in words
    assert "unless last seen beyond the cell's walls" in exits_words(
        TrackerConfig(cell=Box([-3, -3, 0], [3, 3, 3])), 2.0)
    assert "where they were last seen," in exits_words(TrackerConfig(), 0.0)
    assert exits_words(TrackerConfig(exits=[Box([4.5, 0.8, -1.0], [6.0, 2.0, 3.0])]), 2.0) \
        == "[[4.5, 0.8, -1.0] .. [6.0, 2.0, 3.0]]"
    assert "expire rule" in exits_words(TrackerConfig(hidden_bodies="expire"), 2.0)


def test_the_page_has_the_counterexamples_found_on_the_way_with_their_plots(tuned):
    page = _html(tuned)
    cert, _ = read_certificate(tuned / "export" / "certificate.json")
    assert cert["counterexamples"] and all(c["found_for"] == "seed_estimated.yaml (tune)"
                                           for c in cert["counterexamples"])
    assert page.count('<img alt="counterexample') == min(6, len(cert["counterexamples"]))


@pytest.mark.parametrize("fixture", ["exported", "tuned"])
def test_the_page_refers_to_nothing_outside_itself(request, fixture):
    page = _html(request.getfixturevalue(fixture))
    assert "<script" not in page.lower()
    for url in re.findall(r'(?:src|href)\s*=\s*"([^"]*)"', page, flags=re.I):
        assert url.startswith("data:") or url.startswith("#"), url
    assert "url(" not in page and "@import" not in page
    assert "Content-Security-Policy" in page and "default-src 'none'" in page


class _Recorder(http.server.BaseHTTPRequestHandler):
    """A proxy that answers every request 404, so that nothing a browser asks for
    leaves this machine."""

    def _any(self):
        self.send_response(404)
        self.send_header("Content-Length", "0")
        self.end_headers()

    do_GET = do_POST = do_HEAD = do_CONNECT = do_PUT = do_OPTIONS = _any

    def log_message(self, *args):
        pass


@pytest.fixture
def proxy_port():
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Recorder)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


class Browser:
    """A headless Chromium driven over the DevTools protocol through a pipe
    (``--remote-debugging-pipe``: commands on its fd 3, answers on its fd 4, each message
    JSON ended by a NUL byte), so that the requests a page makes are told apart from the
    browser's own background traffic."""

    def __init__(self, profile: Path, proxy_port: int):
        commands, answers = os.pipe(), os.pipe()

        def in_child():  # the pipe ends as fds 3 and 4 (dup2 clears close-on-exec)
            a, b = os.dup(commands[0]), os.dup(answers[1])
            os.dup2(a, 3)
            os.dup2(b, 4)

        self.process = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
             "--disable-background-networking", "--disable-component-update",
             "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
             f"--proxy-server=http://127.0.0.1:{proxy_port}", "--proxy-bypass-list=<-loopback>",
             "--remote-debugging-pipe", "about:blank"],
            preexec_fn=in_child, close_fds=False, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(commands[0])
        os.close(answers[1])
        self.write = os.fdopen(commands[1], "wb")
        self.read = os.fdopen(answers[0], "rb")
        self.messages: queue.Queue = queue.Queue()
        self.events: list[dict] = []
        self.count = 0
        threading.Thread(target=self._receive, daemon=True).start()
        pages = [t for t in self.send("Target.getTargets")["targetInfos"]
                 if t["type"] == "page"]
        self.session = self.send("Target.attachToTarget", {"targetId": pages[0]["targetId"],
                                                           "flatten": True})["sessionId"]
        self.send("Network.enable", session=True)
        self.send("Page.enable", session=True)

    def _receive(self):
        pending = b""
        while chunk := self.read.read1(1 << 16):
            pending += chunk
            *done, pending = pending.split(b"\0")
            for message in done:
                self.messages.put(json.loads(message))
        self.messages.put(None)

    def _next(self, deadline: float) -> dict:
        message = self.messages.get(timeout=max(0.01, deadline - time.monotonic()))
        if message is None:
            raise RuntimeError("the browser closed its pipe")
        return message

    def send(self, method: str, params: dict | None = None, *, session: bool = False,
             timeout: float = 60.0) -> dict:
        self.count += 1
        message = {"id": self.count, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self.session
        self.write.write(json.dumps(message).encode() + b"\0")
        self.write.flush()
        deadline = time.monotonic() + timeout
        while True:
            answer = self._next(deadline)
            if answer.get("id") == self.count:
                assert "error" not in answer, answer
                return answer["result"]
            self.events.append(answer)

    def load(self, page: Path, timeout: float = 60.0) -> list[str]:
        """Opens ``page`` and waits for its load event and a second more; the URLs the
        page requested (its own file and data: URLs left out)."""
        first = len(self.events)
        self.send("Page.navigate", {"url": page.as_uri()}, session=True)
        deadline = time.monotonic() + timeout
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events[first:]):
            self.events.append(self._next(deadline))
        time.sleep(1.0)  # anything the page would start after its load event
        self.send("Runtime.evaluate", {"expression": "1"}, session=True)
        return [e["params"]["request"]["url"] for e in self.events[first:]
                if e.get("method") == "Network.requestWillBeSent"
                and e["params"]["request"]["url"] != page.as_uri()
                and not e["params"]["request"]["url"].startswith("data:")]

    def evaluate(self, expression: str):
        return self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True},
                         session=True)["result"]["value"]

    def close(self):
        try:
            self.send("Browser.close", timeout=10.0)
        except (RuntimeError, queue.Empty, OSError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.write.close()


RENDERED = """JSON.stringify({
  headings: [...document.querySelectorAll('h2')].map(h => h.textContent),
  images: [...document.images].map(i => i.complete && i.naturalWidth > 0),
  height: document.body.scrollHeight,
  signOff: [...document.querySelectorAll('table.sign td')].map(td => td.textContent)})"""


@needs_chromium
def test_the_page_renders_in_a_headless_browser_and_fetches_nothing(tuned, tmp_path,
                                                                    proxy_port):
    browser = Browser(tmp_path / "profile", proxy_port)
    try:
        # The watch works: a page with an external style sheet and image is seen asking.
        control = tmp_path / "control.html"
        control.write_text('<!DOCTYPE html><html><head><link rel="stylesheet" '
                           'href="http://example.invalid/style.css"></head><body>'
                           '<img src="https://example.invalid/pixel.png">x</body></html>')
        asked = browser.load(control)
        assert {"http://example.invalid/style.css",
                "https://example.invalid/pixel.png"} <= set(asked), asked
        report = tuned / "export" / "report.html"
        # Without its Content-Security-Policy too: the page itself asks for nothing.
        bare = tmp_path / "bare.html"
        bare.write_text(re.sub(r'<meta http-equiv="Content-Security-Policy"[^>]*>', "",
                               report.read_text()))
        for page in (report, bare):
            assert browser.load(page) == [], page.name
            rendered = json.loads(browser.evaluate(RENDERED))
            assert rendered["headings"] == SECTIONS, page.name
            assert len(rendered["images"]) >= 2 and all(rendered["images"]), page.name
            assert rendered["height"] > 3000
            assert rendered["signOff"][:5] == ["Integrator", "", "", "", ""]
    finally:
        browser.close()
