"""Headless Chromium driven over the DevTools protocol, for the viewer's test and benchmark.

Uses Debian's chromium and python3-websocket only. WebGL runs on SwiftShader (Chromium's
CPU rasterizer), so no GPU is needed.
"""

import argparse
import base64
import json
import os
import shutil
import subprocess
import tempfile
import time
import urllib.request


class ChromiumMissing(Exception):
    pass


def find_chromium():
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    raise ChromiumMissing("chromium is not installed (Debian package 'chromium')")


SKIP = 77  # the exit code ctest reads as skipped


def test_arguments():
    """The browser tests' command line (--dome, --keep), or None, having said why, when
    Chromium or python3-websocket is missing here."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--dome", required=True, help="the dome executable")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    args = ap.parse_args()
    try:
        find_chromium()
        import websocket  # noqa: F401
    except (ChromiumMissing, ImportError) as e:
        print("SKIPPED: %s (deploy/install-deps.sh installs chromium and python3-websocket)" % e)
        return None
    return args


class Browser:
    def __init__(self, width=1000, height=700):
        import websocket  # python3-websocket

        self.width, self.height = width, height
        self.profile = tempfile.mkdtemp(prefix="dome_chromium_")
        args = [
            find_chromium(), "--headless=new", "--no-sandbox", "--no-first-run",
            "--no-default-browser-check", "--disable-extensions", "--mute-audio",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
            "--user-data-dir=" + self.profile, "--remote-debugging-port=0",
            "--window-size=%d,%d" % (width, height), "about:blank",
        ]
        self.proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        port_file = os.path.join(self.profile, "DevToolsActivePort")
        deadline = time.time() + 30
        while not os.path.exists(port_file) or os.path.getsize(port_file) == 0:
            if time.time() > deadline or self.proc.poll() is not None:
                self.close()
                raise RuntimeError("chromium did not start its DevTools endpoint")
            time.sleep(0.05)
        port = open(port_file).read().split()[0]
        with urllib.request.urlopen("http://127.0.0.1:%s/json/list" % port) as r:
            pages = [t for t in json.load(r) if t["type"] == "page"]
        self.ws = websocket.create_connection(pages[0]["webSocketDebuggerUrl"], timeout=60)
        self.next_id = 0
        self.call("Page.enable")
        self.call("Runtime.enable")
        self.call("Emulation.setDeviceMetricsOverride", width=width, height=height,
                  deviceScaleFactor=1, mobile=False)
        self.console = []

    def call(self, method, **params):
        self.next_id += 1
        self.ws.send(json.dumps({"id": self.next_id, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("method") == "Runtime.exceptionThrown":
                self.console.append(str(msg["params"]["exceptionDetails"]))
            if msg.get("id") == self.next_id:
                if "error" in msg:
                    raise RuntimeError("%s: %s" % (method, msg["error"]))
                return msg["result"]

    def eval(self, expression):
        r = self.call("Runtime.evaluate", expression=expression, returnByValue=True,
                      awaitPromise=True)
        if "exceptionDetails" in r:
            raise RuntimeError("%s: %s" % (expression, r["exceptionDetails"]))
        return r["result"].get("value")

    def navigate(self, url):
        self.call("Page.navigate", url=url)
        self.wait_for("document.readyState === 'complete' && !!window.domeViewer", 90)

    def wait_for(self, expression, timeout_s):
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            if self.eval(expression):
                return
            time.sleep(0.05)
        raise AssertionError("timed out waiting for: " + expression)

    def click(self, x, y):
        for kind in ("mouseMoved", "mousePressed", "mouseReleased"):
            self.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left",
                      clickCount=0 if kind == "mouseMoved" else 1)

    def click_element(self, selector):
        r = self.eval("(() => { const r = document.querySelector(%s).getBoundingClientRect();"
                      " return [r.left + r.width / 2, r.top + r.height / 2]; })()"
                      % json.dumps(selector))
        self.click(r[0], r[1])

    def screenshot_png(self, scale=1.0):
        clip = {"x": 0, "y": 0, "width": self.width, "height": self.height, "scale": scale}
        return base64.b64decode(self.call("Page.captureScreenshot", format="png", clip=clip)["data"])

    def close(self):
        try:
            if getattr(self, "ws", None):
                try:
                    self.call("Browser.close")
                except Exception:
                    pass
                self.ws.close()
        finally:
            if self.proc.poll() is None:
                self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
            shutil.rmtree(self.profile, ignore_errors=True)


class DomeView:
    """`dome view OUT --take TAKE --port 0` as a process; .url is where it serves."""

    def __init__(self, dome, out, take, extra=()):
        self.proc = subprocess.Popen([dome, "view", out, "--take", take, "--port", "0", *extra],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        line = self.proc.stdout.readline()
        if "serving http://" not in line:
            self.proc.kill()
            raise RuntimeError("dome view did not start: " + line + self.proc.stdout.read())
        self.url = line.split("serving ")[1].split()[0]

    def stop(self):
        """Sends SIGTERM; returns the exit code."""
        self.proc.terminate()
        try:
            return self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return None
