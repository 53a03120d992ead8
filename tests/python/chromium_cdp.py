"""Debian's headless chromium driven over the DevTools protocol on a pipe (``--remote-debugging-pipe``: JSON
messages ending in a NUL byte on file descriptors 3 and 4), so a test can press keys, click and turn the
mouse wheel as a reader does, read canvases back and see every request the page makes, with no library
beyond the standard one. Used by tests/python/test_viewer.py."""
from __future__ import annotations

import json
import os
import select
import shutil
import subprocess
import time

CHROMIUM = shutil.which("chromium")


class Browser:
    """One headless chromium with one page; ``requests`` lists every URL the page asked for."""

    def __init__(self, width: int = 1400, height: int = 1000):
        assert CHROMIUM, "chromium is missing: make build installs it (scripts/install-deps.sh)"
        to_chrome, self._w = os.pipe()
        self._r, from_chrome = os.pipe()

        def fds():  # chromium reads commands on fd 3 and writes answers on fd 4
            os.dup2(to_chrome, 3)
            os.dup2(from_chrome, 4)

        self.proc = subprocess.Popen(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
             "--remote-debugging-pipe", f"--window-size={width},{height}", "about:blank"],
            pass_fds=(3, 4, to_chrome, from_chrome), preexec_fn=fds, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(to_chrome)
        os.close(from_chrome)
        self._buf, self._id, self.session, self.events = b"", 0, None, []

    def _message(self, timeout: float) -> dict:
        end = time.monotonic() + timeout
        while b"\0" not in self._buf:
            left = end - time.monotonic()
            if left <= 0 or not select.select([self._r], [], [], left)[0]:
                raise TimeoutError("chromium did not answer")
            chunk = os.read(self._r, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed its pipe")
            self._buf += chunk
        message, self._buf = self._buf.split(b"\0", 1)
        return json.loads(message)

    def send(self, method: str, timeout: float = 60, browser: bool = False, **params):
        """One DevTools command (to the page's session unless ``browser``); returns its result."""
        self._id += 1
        message = {"id": self._id, "method": method, "params": params}
        if self.session and not browser:
            message["sessionId"] = self.session
        os.write(self._w, json.dumps(message).encode() + b"\0")
        while True:
            m = self._message(timeout)
            if m.get("id") == self._id:
                if "error" in m:
                    raise RuntimeError(f"{method}: {m['error']}")
                return m.get("result", {})
            self.events.append(m)

    def open(self, url: str) -> None:
        target = self.send("Target.createTarget", browser=True, url="about:blank")["targetId"]
        self.session = self.send("Target.attachToTarget", browser=True, targetId=target, flatten=True)["sessionId"]
        for domain in ("Network", "Page", "Runtime", "Log"):
            self.send(f"{domain}.enable")
        self.send("Page.navigate", url=url)
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events):
            self.events.append(self._message(120))

    @property
    def requests(self) -> list:
        return [e["params"]["request"]["url"] for e in self.events if e.get("method") == "Network.requestWillBeSent"]

    @property
    def errors(self) -> list:
        """Exceptions thrown in the page and console errors (a CSP violation is one)."""
        out = [e["params"]["exceptionDetails"].get("text", "") + " " + str(e["params"]["exceptionDetails"].get(
            "exception", {}).get("description", "")) for e in self.events if e.get("method") == "Runtime.exceptionThrown"]
        out += [e["params"]["entry"]["text"] for e in self.events
                if e.get("method") == "Log.entryAdded" and e["params"]["entry"]["level"] == "error"]
        return out

    def eval(self, expression: str, timeout: float = 60):
        r = self.send("Runtime.evaluate", timeout=timeout, expression=expression, awaitPromise=True,
                      returnByValue=True)
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def wait(self, expression: str, timeout: float = 60):
        """Polls ``expression`` until it is truthy; returns its value."""
        end = time.monotonic() + timeout
        while True:
            value = self.eval(expression)
            if value:
                return value
            if time.monotonic() > end:
                raise TimeoutError(f"never true: {expression}")
            time.sleep(0.05)

    def click(self, selector: str) -> None:
        """A left click at the middle of the element ``selector`` (as a reader's mouse does)."""
        x, y = self.eval(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                         f" e.scrollIntoView({{block: 'center'}}); const r = e.getBoundingClientRect();"
                         f" return [r.left + r.width / 2, r.top + r.height / 2]; }})()")
        for kind in ("mousePressed", "mouseReleased"):
            self.send("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def key(self, key: str, code: str, kind: str = "press", text: str | None = None) -> None:
        """Key events: "down", "up" or "press" (both)."""
        kinds = {"press": ("keyDown", "keyUp"), "down": ("keyDown",), "up": ("keyUp",)}[kind]
        for k in kinds:
            extra = {"text": text} if text and k == "keyDown" else {}
            self.send("Input.dispatchKeyEvent", type=k, key=key, code=code, **extra)

    def wheel(self, selector: str, dx: float, dy: float, delta_y: float) -> None:
        """The mouse wheel turned over element ``selector`` at (dx, dy) CSS pixels from its top left."""
        x, y = self.eval(f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
                         f" e.scrollIntoView({{block: 'center'}}); const r = e.getBoundingClientRect();"
                         f" return [r.left + {dx}, r.top + {dy}]; }})()")
        self.send("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y)
        self.send("Input.dispatchMouseEvent", type="mouseWheel", x=x, y=y, deltaX=0, deltaY=delta_y)

    def canvas(self, selector: str, x: int = 0, y: int = 0, w: int = 0, h: int = 0, step: int = 1):
        """(rows, columns, 4) uint8 pixels of a canvas read back through getImageData: the rectangle at
        (x, y) of w x h canvas pixels (the whole canvas by default), every ``step``-th row and column."""
        import base64

        import numpy as np
        w, h, data = self.eval(
            f"(() => {{ const c = document.querySelector({json.dumps(selector)}), w = {w} || c.width, h = {h} || c.height;"
            f" const d = c.getContext('2d').getImageData({x}, {y}, w, h).data, step = {step}, out = [];"
            f" for (let r = 0; r < h; r += step) for (let q = 0; q < w; q += step) {{ const i = 4 * (r * w + q);"
            f" out.push(d[i], d[i + 1], d[i + 2], d[i + 3]); }}"
            f" let s = ''; for (let i = 0; i < out.length; i += 32768) s += String.fromCharCode.apply(null,"
            f" out.slice(i, i + 32768)); return [Math.ceil(w / step), Math.ceil(h / step), btoa(s)]; }})()")
        return np.frombuffer(base64.b64decode(data), np.uint8).reshape(h, w, 4)

    def close(self) -> None:
        try:
            self.send("Browser.close", browser=True, timeout=10)
        except (RuntimeError, TimeoutError, OSError):
            pass
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        os.close(self._w)
        os.close(self._r)
