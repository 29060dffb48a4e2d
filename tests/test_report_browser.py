"""The rendered report in a real browser: headless Chromium through the DevTools protocol.

Fails on a JavaScript error, an image that does not decode or a request that leaves
the machine, and saves a screenshot next to the report. Runs where Debian's
``chromium`` is installed (CI installs it), else skips.
"""

from __future__ import annotations

import base64
import itertools
import json
import re
import shutil
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest

websocket = pytest.importorskip("websocket", reason="websocket-client is not installed (envs/requirements.txt)")

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = [
    pytest.mark.integration,
    pytest.mark.browser,
    pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (apt-get install chromium)"),
]

#: Schemes a page opened from disk may load without the network.
LOCAL_SCHEMES = ("file:", "data:", "about:", "blob:", "chrome:", "devtools:")

FIND_BROKEN_IMAGES = """
Promise.all(Array.from(document.images).map((img, i) =>
    img.decode().then(() => img.naturalWidth > 0 ? null : `image ${i} has no pixels`,
                      () => `image ${i} does not decode: ${img.src.slice(0, 60)}`)))
  .then(found => found.filter(x => x !== null))
"""


class Page:
    """One browser tab: DevTools commands, and the errors and requests it reports."""

    def __init__(self, url: str):
        self.socket = websocket.create_connection(url, timeout=60)
        self.ids = itertools.count(1)
        self.errors: list[str] = []
        self.requests: list[str] = []
        for domain in ("Page", "Runtime", "Log", "Network"):
            self.call(f"{domain}.enable")

    def call(self, method: str, **params):
        """Send a command and return its result, recording the events that arrive meanwhile."""
        ident = next(self.ids)
        self.socket.send(json.dumps({"id": ident, "method": method, "params": params}))
        while True:
            message = json.loads(self.socket.recv())
            if message.get("id") == ident:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message["result"]
            self._event(message)

    def _event(self, message: dict) -> None:
        method, params = message.get("method"), message.get("params", {})
        if method == "Runtime.exceptionThrown":
            details = params["exceptionDetails"]
            self.errors.append(f"JavaScript: {details.get('exception', {}).get('description', details['text'])}")
        elif method == "Runtime.consoleAPICalled" and params["type"] == "error":
            self.errors.append(f"console: {[a.get('value', a.get('description')) for a in params['args']]}")
        elif method == "Log.entryAdded" and params["entry"]["level"] == "error":
            self.errors.append(f"log: {params['entry']['text']} {params['entry'].get('url', '')}")
        elif method == "Network.requestWillBeSent":
            self.requests.append(params["request"]["url"])

    def open(self, url: str, seconds: float = 60) -> None:
        """Navigate and wait for the load event (and a moment for late scripts)."""
        self.errors.clear()
        self.requests.clear()
        self.call("Page.navigate", url=url)
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            message = json.loads(self.socket.recv())
            self._event(message)
            if message.get("method") == "Page.loadEventFired":
                self.evaluate("new Promise(done => setTimeout(done, 500))")
                return
        raise TimeoutError(f"{url} did not load in {seconds} s")

    def evaluate(self, expression: str):
        result = self.call("Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
        return result["result"].get("value")

    def problems(self) -> list[str]:
        """JavaScript errors, undecodable images and requests to the network of the open page."""
        remote = [f"network request: {url}" for url in self.requests if not url.startswith(LOCAL_SCHEMES)]
        return self.errors + self.evaluate(FIND_BROKEN_IMAGES) + remote

    def screenshot(self, path: Path) -> None:
        path.write_bytes(base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"]))


@pytest.fixture()
def browser_page(tmp_path):
    """A tab of a headless Chromium with its own profile, started and stopped here."""
    profile = tmp_path / "profile"
    process = subprocess.Popen([
        CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-default-apps",
        f"--user-data-dir={profile}", "--remote-debugging-port=0", "--window-size=1280,1600", "about:blank",
    ], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    page = None
    try:
        port_file = profile / "DevToolsActivePort"
        deadline = time.monotonic() + 60
        while not (port_file.exists() and port_file.read_text().strip()) and time.monotonic() < deadline:
            time.sleep(0.1)
        port = int(port_file.read_text().split()[0])
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=30) as response:
            target = next(t for t in json.load(response) if t["type"] == "page")
        page = Page(target["webSocketDebuggerUrl"])
        yield page
    finally:
        if page is not None:
            page.socket.close()
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def test_the_checks_catch_a_script_error_a_broken_image_and_a_remote_request(browser_page, tmp_path):
    bad = tmp_path / "bad.html"
    bad.write_text(
        '<html><body><img src="data:image/png;base64,iVBORw0KGgoAAAANSUhEUgAAAAEAAAAB">'
        '<script src="https://cdn.invalid/x.js"></script><script>undefinedFunction()</script></body></html>'
    )
    browser_page.open(bad.as_uri())
    found = "\n".join(browser_page.problems())
    assert "undefinedFunction" in found and "does not decode" in found and "https://cdn.invalid/x.js" in found


def test_report_opens_in_a_browser_without_errors(browser_page, smoke_run):
    report = smoke_run / "results/smoke/report/report.html"
    browser_page.open(report.as_uri())
    assert browser_page.problems() == []
    assert browser_page.evaluate("document.images.length") >= 5
    text = browser_page.evaluate("document.body.innerText")
    assert not re.search(r"\bnan\b", text) and "Provenance" in text  # a missing value prints as "—"
    browser_page.screenshot(report.with_name("screenshot.png"))
    assert report.with_name("screenshot.png").stat().st_size > 10_000
