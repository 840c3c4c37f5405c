#!/usr/bin/env python3
"""Load an HTML page in headless Chromium and check it as a reader would see it.

    page_check.py PAGE.html [--screenshot OUT.png [--screenshot-of CSS_SELECTOR]]
                  [--size 1200x900] [--wait-ms 500]
                  [--canvas CSS_SELECTOR]... [--eval JS]... [--expect-text TEXT]...

--screenshot writes the top of the page as the window shows it, or with --screenshot-of the
box of one element wherever it is on the page (a figure or the viewer far down a report).

Exit 0 when the page loaded with no console error, no uncaught exception and no failed resource,
and every check held; exit 1 with one line per failure otherwise; exit 77 when Chromium is not
installed (the caller's test is then skipped, with this reason).

Checks:
  --canvas SEL       the element SEL exists and its screenshot is not blank: at least 1% of its
                     pixels differ from its most common colour (a WebGL canvas that drew nothing
                     is one colour).
  --eval JS          JS is evaluated after the load; its value must be truthy (a promise is
                     awaited). Use it to click an element and read what the page then shows.
  --expect-text T    the page's text (document.body.innerText) contains T.

Chromium is driven through its DevTools protocol on a pipe (--remote-debugging-pipe: commands
on fd 3, replies and events on fd 4, each a JSON text ended by a NUL byte), so console levels
are known exactly: the --enable-logging output logs every console call at one level. WebGL runs
on SwiftShader, Chromium's software GPU, so no GPU or display is needed.
"""
import argparse
import base64
import json
import os
import select
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib


def chromium_binary():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


class DevTools:
    """One browser over --remote-debugging-pipe, with one page session attached."""

    def __init__(self, binary, width, height, timeout_s):
        self.profile = tempfile.mkdtemp(prefix="pm-page-check-")
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()
        args = [binary, "--headless=new", "--no-sandbox", "--no-first-run",
                "--no-default-browser-check", "--disable-extensions", "--disable-gpu",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--allow-file-access-from-files", "--remote-debugging-pipe",
                "--user-data-dir=" + self.profile, "--window-size=%d,%d" % (width, height),
                "about:blank"]

        def child_fds():
            # Through fds above both targets first: a pipe end may itself be fd 3 or 4.
            os.dup2(to_browser_r, 100)
            os.dup2(from_browser_w, 101)
            os.dup2(100, 3)
            os.dup2(101, 4)

        self.proc = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL, preexec_fn=child_fds,
                                     close_fds=False)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.deadline = time.monotonic() + timeout_s
        self.next_id = 0
        self.buffer = b""
        self.events = []
        self.session = None

    def close(self):
        try:
            if self.proc.poll() is None:
                try:
                    self.send("Browser.close", session=False, wait=False)
                    self.proc.wait(timeout=10)
                except Exception:
                    pass
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
        finally:
            for fd in (self.to_browser, self.from_browser):
                try:
                    os.close(fd)
                except OSError:
                    pass
            shutil.rmtree(self.profile, ignore_errors=True)

    def _read_message(self):
        while b"\0" not in self.buffer:
            left = self.deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("Chromium did not answer in time")
            ready, _, _ = select.select([self.from_browser], [], [], left)
            if not ready:
                continue
            chunk = os.read(self.from_browser, 1 << 16)
            if not chunk:
                raise RuntimeError("Chromium exited (status %s)" % self.proc.poll())
            self.buffer += chunk
        text, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(text)

    def send(self, method, params=None, session=True, wait=True):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(msg).encode() + b"\0")
        if not wait:
            return None
        while True:
            reply = self._read_message()
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError("%s: %s" % (method, reply["error"].get("message")))
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method):
        for i, ev in enumerate(self.events):
            if ev.get("method") == method:
                return self.events.pop(i)
        while True:
            ev = self._read_message()
            if ev.get("method") == method:
                return ev
            self.events.append(ev)

    def drain(self, seconds):
        end = min(self.deadline, time.monotonic() + seconds)
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return
            ready, _, _ = select.select([self.from_browser], [], [], left)
            if ready:
                if b"\0" not in self.buffer:
                    chunk = os.read(self.from_browser, 1 << 16)
                    if not chunk:
                        return
                    self.buffer += chunk
                while b"\0" in self.buffer:
                    text, self.buffer = self.buffer.split(b"\0", 1)
                    self.events.append(json.loads(text))


def png_pixels(data):
    """(width, height, rows of RGB tuples) of an 8-bit RGB or RGBA, non-interlaced PNG: the
    form Chromium's screenshots take."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or colour not in (2, 6) or interlace:
                raise ValueError("PNG form not handled (depth %d, colour %d)" % (depth, colour))
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        filt = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if filt == 1:
                line[i] = (line[i] + a) & 255
            elif filt == 2:
                line[i] = (line[i] + b) & 255
            elif filt == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif filt == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 255
        rows.append([tuple(line[x * channels:x * channels + 3]) for x in range(width)])
        prev = line
    return width, height, rows


def not_blank_fraction(png):
    """The fraction of pixels that differ from the most common colour."""
    _, _, rows = png_pixels(png)
    counts = {}
    for row in rows:
        for px in row:
            counts[px] = counts.get(px, 0) + 1
    total = sum(counts.values())
    return (total - max(counts.values())) / total if total else 0.0


def element_box(dt, sel):
    """The box [x, y, width, height] of the first element SEL in page coordinates (the box seen
    in the viewport, plus the scroll, after scrolling it into view), or None."""
    r = dt.send("Runtime.evaluate", {
        "expression": "(function(){var e=document.querySelector(%s);if(!e)return null;"
                      "e.scrollIntoView();var b=e.getBoundingClientRect();"
                      "return [b.x+window.scrollX,b.y+window.scrollY,b.width,b.height];})()"
                      % json.dumps(sel),
        "returnByValue": True})
    return r.get("result", {}).get("value")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("page")
    ap.add_argument("--screenshot")
    ap.add_argument("--screenshot-of")
    ap.add_argument("--size", default="1200x900")
    ap.add_argument("--wait-ms", type=int, default=500)
    ap.add_argument("--timeout", type=float, default=60)
    ap.add_argument("--canvas", action="append", default=[])
    ap.add_argument("--eval", action="append", default=[])
    ap.add_argument("--expect-text", action="append", default=[])
    a = ap.parse_args()

    binary = chromium_binary()
    if not binary:
        print("page_check: chromium is not installed (scripts/install-deps.sh installs it)")
        return 77
    if not os.path.isfile(a.page):
        print("page_check: %s: no such file" % a.page)
        return 1
    try:
        width, height = (int(v) for v in a.size.split("x"))
    except ValueError:
        print("page_check: --size takes WIDTHxHEIGHT, not '%s'" % a.size)
        return 2

    failures = []
    dt = DevTools(binary, width, height, a.timeout)
    try:
        target = dt.send("Target.createTarget", {"url": "about:blank"}, session=False)
        attached = dt.send("Target.attachToTarget",
                           {"targetId": target["targetId"], "flatten": True}, session=False)
        dt.session = attached["sessionId"]
        for domain in ("Page", "Runtime", "Log", "Network"):
            dt.send(domain + ".enable")
        dt.send("Emulation.setDeviceMetricsOverride",
                {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})
        dt.send("Page.navigate", {"url": "file://" + os.path.abspath(a.page)})
        dt.wait_event("Page.loadEventFired")
        dt.drain(a.wait_ms / 1000.0)

        for js in a.eval:
            r = dt.send("Runtime.evaluate", {"expression": js, "awaitPromise": True,
                                             "returnByValue": True})
            if "exceptionDetails" in r:
                failures.append("--eval %s: threw %s" % (js, r["exceptionDetails"].get("text")))
            elif not r.get("result", {}).get("value"):
                failures.append("--eval %s: gave %r" % (js, r.get("result", {}).get("value")))
        dt.drain(0.2)

        text = dt.send("Runtime.evaluate", {"expression": "document.body.innerText",
                                            "returnByValue": True})
        body = text.get("result", {}).get("value") or ""
        for t in a.expect_text:
            if t not in body:
                failures.append("the page's text has no '%s'" % t)

        for sel in a.canvas:
            box = element_box(dt, sel)
            if not box or box[2] < 1 or box[3] < 1:
                failures.append("no visible element '%s'" % sel)
                continue
            shot = dt.send("Page.captureScreenshot", {
                "format": "png", "clip": {"x": box[0], "y": box[1], "width": box[2],
                                          "height": box[3], "scale": 1}})
            frac = not_blank_fraction(base64.b64decode(shot["data"]))
            if frac < 0.01:
                failures.append("'%s' is blank (%.4f of its pixels differ from its background)"
                                % (sel, frac))

        if a.screenshot and a.screenshot_of:
            box = element_box(dt, a.screenshot_of)
            if not box or box[2] < 1 or box[3] < 1:
                failures.append("no visible element '%s' to take a screenshot of" % a.screenshot_of)
                shot = None
            else:
                dt.drain(0.2)  # a canvas redraws after the scroll
                shot = dt.send("Page.captureScreenshot", {
                    "format": "png", "captureBeyondViewport": True,
                    "clip": {"x": box[0], "y": box[1], "width": box[2], "height": box[3], "scale": 1}})
        elif a.screenshot:
            dt.send("Runtime.evaluate", {"expression": "window.scrollTo(0,0)"})
            shot = dt.send("Page.captureScreenshot", {"format": "png"})
        if a.screenshot and shot:
            tmp = a.screenshot + ".part"
            with open(tmp, "wb") as f:
                f.write(base64.b64decode(shot["data"]))
            os.replace(tmp, a.screenshot)

        for ev in dt.events:
            m, p = ev.get("method"), ev.get("params", {})
            if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
                args = " ".join(str(x.get("value", x.get("description", ""))) for x in
                                p.get("args", []))
                failures.append("console error: " + args)
            elif m == "Runtime.exceptionThrown":
                d = p.get("exceptionDetails", {})
                failures.append("uncaught exception: %s %s" % (
                    d.get("text", ""), d.get("exception", {}).get("description", "")))
            elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
                e = p["entry"]
                failures.append("error (%s): %s %s" % (e.get("source"), e.get("text"),
                                                      e.get("url", "")))
            elif m == "Network.loadingFailed":
                failures.append("failed to load: %s" % p.get("errorText"))
    except (RuntimeError, TimeoutError, ValueError, KeyError) as e:
        failures.append("page_check: %s" % e)
    finally:
        dt.close()

    for f in failures:
        print("%s: %s" % (a.page, f.replace("\n", " ")))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
