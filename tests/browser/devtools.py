"""A headless Chromium driven over the DevTools protocol through --remote-debugging-pipe (its
fds 3 and 4, NUL-separated JSON), with python3's standard library only: no port, no pip, no node.

    with Browser(chrome_path, profile_dir, log_path) as b:
        page = b.new_page()              # one tab, attached (flat sessions)
        page.call("Page.navigate", url=...)
        b.wait_event(lambda e: e["method"] == "Page.loadEventFired", timeout=30)

Every call and wait has a timeout; leaving the `with` closes the browser and kills its process
group (the browser and every process it started, nothing else).
"""

import fcntl
import json
import os
import signal
import subprocess
import threading
import time


class DevToolsError(Exception):
    """The browser answered a command with an error, did not answer in time, or went away."""


class Browser:
    def __init__(self, chrome, profile, log, window=(1100, 760)):
        self.chrome, self.profile, self.log, self.window = chrome, profile, log, window
        self.proc = None
        self._next = 0
        self._lock = threading.Condition()
        self._write = threading.Lock()
        self._answers = {}
        self._listeners = []  # functions called (on the reader thread) with every event
        self.events = []  # (monotonic time, event) of every event kept by `keep`
        self.keep = lambda e: True
        self.gone = None

    def __enter__(self):
        to_browser_r, self._to_browser = os.pipe()
        self._from_browser, from_browser_w = os.pipe()

        def fds():  # in the child, before exec: the pipe's ends as fds 3 and 4
            a = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD, 10)
            b = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD, 10)
            os.dup2(a, 3)
            os.dup2(b, 4)

        w, h = self.window
        args = [self.chrome, "--headless", "--no-sandbox", "--disable-gpu",
                "--disable-dev-shm-usage", "--no-first-run", "--no-default-browser-check",
                "--hide-scrollbars", "--mute-audio", "--disable-extensions",
                "--user-data-dir=" + self.profile, "--window-size=%d,%d" % (w, h),
                "--remote-debugging-pipe", "about:blank"]
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=log, stderr=log,
                                         preexec_fn=fds, pass_fds=(3, 4),
                                         start_new_session=True)
        os.close(to_browser_r)
        os.close(from_browser_w)
        threading.Thread(target=self._read, daemon=True).start()
        self.call("Browser.getVersion", timeout=30)
        return self

    def __exit__(self, *exc):
        if self.proc is None:
            return
        if self.proc.poll() is None and self.gone is None:
            try:
                self.call("Browser.close", timeout=5)
            except DevToolsError:
                pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            pass
        try:  # the renderers and helpers it started, in its own session
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            pass
        for fd in (self._to_browser, self._from_browser):
            try:
                os.close(fd)
            except OSError:
                pass

    def _read(self):
        buf = b""
        while True:
            try:
                chunk = os.read(self._from_browser, 1 << 20)
            except OSError:
                chunk = b""
            if not chunk:
                with self._lock:
                    self.gone = "the browser closed its DevTools pipe"
                    self._lock.notify_all()
                return
            buf += chunk
            *messages, buf = buf.split(b"\0")
            for raw in messages:
                m = json.loads(raw)
                if "id" in m:
                    with self._lock:
                        self._answers[m["id"]] = m
                        self._lock.notify_all()
                else:
                    for f in self._listeners:
                        f(m)
                    if self.keep(m):
                        with self._lock:
                            self.events.append((time.monotonic(), m))
                            self._lock.notify_all()

    def listen(self, f):
        """Calls f(event) for every event, on the reader thread, as it arrives (f must not wait
        for an answer of the browser there: that thread reads the answers)."""
        self._listeners.append(f)

    def call(self, method, session=None, timeout=30, **params):
        with self._lock:
            self._next += 1
            n = self._next
        msg = {"id": n, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        data = json.dumps(msg).encode() + b"\0"
        try:
            with self._write:  # one message at a time, whichever thread calls
                while data:
                    data = data[os.write(self._to_browser, data):]
        except OSError as e:
            raise DevToolsError("%s: cannot write to the browser: %s" % (method, e))
        deadline = time.monotonic() + timeout
        with self._lock:
            while n not in self._answers:
                left = deadline - time.monotonic()
                if self.gone or left <= 0:
                    raise DevToolsError("%s: %s" % (method, self.gone or "no answer in %g s" % timeout))
                self._lock.wait(left)
            m = self._answers.pop(n)
        if "error" in m:
            raise DevToolsError("%s: %s" % (method, m["error"].get("message", m["error"])))
        return m.get("result", {})

    def wait_event(self, match, timeout, since=0.0):
        """The first kept event at or after monotonic time `since` for which match(event)."""
        deadline = time.monotonic() + timeout
        with self._lock:
            while True:
                for t, e in self.events:
                    if t >= since and match(e):
                        return e
                left = deadline - time.monotonic()
                if self.gone or left <= 0:
                    return None
                self._lock.wait(min(left, 0.5))

    def new_page(self):
        target = self.call("Target.createTarget", url="about:blank")["targetId"]
        session = self.call("Target.attachToTarget", targetId=target, flatten=True)["sessionId"]
        return Page(self, session)


class Page:
    """One tab: its commands go to its session."""

    def __init__(self, browser, session):
        self.browser, self.session = browser, session

    def call(self, method, timeout=30, **params):
        return self.browser.call(method, session=self.session, timeout=timeout, **params)

    def evaluate(self, expression, timeout=30):
        """The value of a JavaScript expression in the page (awaited if a promise)."""
        r = self.call("Runtime.evaluate", timeout=timeout, expression=expression,
                      returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in r:
            d = r["exceptionDetails"]
            raise DevToolsError("script error: %s" % d.get("exception", {}).get("description", d.get("text")))
        return r["result"].get("value")
