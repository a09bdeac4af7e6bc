"""The live view in a real browser: ONE headless Chromium page stays open on a
distributed render's --http page and is captured at three moments; the checks prove that tiles
reach an open page by its event stream and are drawn where they belong.

Run by tests/browser/live_view.sh (which installs Chromium):
    python3 live_view.py CHROMIUM PARRT TMPDIR

Chromium is up before the render starts, driven over the DevTools protocol (devtools.py). The
page is opened once the render has tiles (it joins a running render), over a slow link (see
SlowLink); the browser's network events count the page's `tiles` and `reload` events and its
loads of image.png. Captures (a screenshot, and read in one script run the page's numbers,
worker rows and canvas pixels):
  1. mid-render, once the page counts 5 % of the tiles done, its own loads of the whole image
     over for 0.5 s, and a `tiles` event came after them (GET /frame just before: the tiles
     the server had then);
  2. mid-render again, once the page counts 10 % more tiles done;
  3. at the end, once the page shows the finished image.
Checks: at 1 and 2 the page says rendering, 0 < done < total, one row per worker, and part of
the image is drawn and part is not (screenshot and canvas); between 1 and 2 the page received
`tiles` events and no `reload` event and loaded no image.png, and more of the image is drawn
at 2 than at 1 (canvas tiles and screenshot pixels): the growth came from `tiles` events; every
tile the server had at 1 is drawn at 2 (none lost); every tile drawn at 1 and 2 equals that
tile of the PNG parrt wrote (a tile drawn in the wrong place or colour fails); at the end every
canvas tile equals the PNG, the screenshot's image box has nothing undrawn and its mean colour
is the PNG's, state done, every tile counted, one row per worker.

Canvas against PNG: both are 8-bit sRGB and parrt's PNG carries no colour profile, so Chromium
draws its pixels unchanged (measured: no difference at all); a channel may differ by at most
TOLERANCE (1) in case a build rounds on the way, and a drawn tile is wrong past that. The
screenshot scales the image to its box with nearest-neighbour sampling (`image-rendering:
pixelated`), so its mean is the PNG's over a subset of its pixels: within SHOT_MEAN_TOLERANCE
(2 of 255) per channel (measured: equal to 0.1).

LIVE_VIEW_BREAK shows that the checks can fail, with a script Chromium runs in the page before
the page's own (the page itself is unchanged): `tiles` drops the page's `tiles` listener (the
page then only shows the image it loads), `offset` draws every tile of a `tiles` event 16
pixels to the right of its place. Either must make this test fail.

Environment: LIVE_VIEW_SIZE (image side, default 768), LIVE_VIEW_WORK (seconds of one-thread
work the render is sized to from a calibration render, default 20; it runs on two one-thread
workers), LIVE_VIEW_SPP (samples per pixel, instead of the calibration), LIVE_VIEW_SHOTS (keep
the screenshots there: mid-render.png, mid-render-later.png, finished.png), LIVE_VIEW_FULL_RATE
(passed as --http-full-rate, in megapixels a second: set low, the tiles come as block means,
which the mid-render checks then also accept, and must see; the end must still be exact).
"""

import base64
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
import urllib.request

import devtools
import png

TILE = 16
WORKERS = 2
TOLERANCE = 1
SHOT_MEAN_TOLERANCE = 2.0
WINDOW = (1100, 760)
UNDRAWN = (b"\0\0\0", b"\x22\x22\x22")  # black (not rendered, in the image the page loads), #222 (before any image)

BREAKS = {
    "tiles": """
        const add = EventTarget.prototype.addEventListener;
        EventSource.prototype.addEventListener = function (type, ...rest) {
          if (type !== "tiles") return add.call(this, type, ...rest);
        };""",
    "offset": """
        const draw = CanvasRenderingContext2D.prototype.drawImage;
        CanvasRenderingContext2D.prototype.drawImage = function (img, ...a) {
          if (img instanceof ImageBitmap && a.length === 8) a[4] += 16;
          return draw.call(this, img, ...a);
        };""",
}

# What the page shows, read in one go (one task of the page: nothing is drawn in between).
READ = """(() => {
  const c = document.getElementById("img"), txt = id => document.getElementById(id).textContent;
  const r = { state: txt("state"), done: Number(txt("done")), total: Number(txt("total")),
              workers: document.querySelectorAll("#workers tbody tr.worker").length,
              width: c.width, height: c.height };
  if (%s) {
    const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
    const rgb = new Uint8Array(c.width * c.height * 3);
    for (let i = 0, j = 0; i < d.length; i += 4, j += 3) {
      rgb[j] = d[i]; rgb[j + 1] = d[i + 1]; rgb[j + 2] = d[i + 2];
    }
    let s = "";
    for (let i = 0; i < rgb.length; i += 0x8000) s += String.fromCharCode.apply(null, rgb.subarray(i, i + 0x8000));
    r.rgb = btoa(s);
  }
  return r;
})()"""


class Fail(Exception):
    pass


def say(*a):
    print("live-view:", *a, flush=True)


def check(ok, what, failures):
    print(("  ok   " if ok else "  FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


class Render:
    """`parrt render` with --http on loopback, in a process group of its own (its workers too),
    ended on exit; its stderr kept in a file and scanned for its address and its end."""

    def __init__(self, parrt, args, log):
        self.lines, self.log = [], log
        self.proc = subprocess.Popen([parrt, "render", *args], stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                     start_new_session=True)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        with open(self.log, "wb") as f:
            for line in self.proc.stderr:
                f.write(line)
                f.flush()
                self.lines.append(line.decode(errors="replace").rstrip("\n"))

    def line(self, prefix):
        return next((l[len(prefix):] for l in self.lines if l.startswith(prefix)), None)

    def end(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)  # ends the linger
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                pass
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        self.proc.wait()


class Watch:
    """The page's network as Chromium sees it (called on the DevTools reader thread)."""

    def __init__(self):
        self.tiles, self.reloads, self.images = [], [], {}  # images: request id -> [sent, ended]

    def __call__(self, e):
        m, p, t = e["method"], e.get("params", {}), time.monotonic()
        if m == "Network.eventSourceMessageReceived":
            {"tiles": self.tiles, "reload": self.reloads}.get(p.get("eventName"), []).append(t)
        elif m == "Network.requestWillBeSent" and "/image.png" in p["request"]["url"]:
            self.images[p["requestId"]] = [t, None]
        elif m in ("Network.loadingFinished", "Network.loadingFailed") and p.get("requestId") in self.images:
            self.images[p["requestId"]][1] = t

    def quiet_since(self):
        """Since when no image.png load was under way and no reload event came (None: one is now)."""
        spans = list(self.images.values())
        if any(end is None for _, end in spans):
            return None
        return max([end for _, end in spans] + self.reloads[-1:] + [0.0])

    def between(self, t0, t1):
        """tiles events, reload events, image.png loads touching [t0, t1]."""
        n = lambda ts: sum(1 for t in list(ts) if t0 <= t <= t1)
        spans = list(self.images.values())  # one copy: the reader thread adds to it
        loads = sum(1 for s, e in spans if s <= t1 and (e is None or e >= t0))
        return n(self.tiles), n(self.reloads), loads


class SlowLink:
    """The page joins the running render over a slow link: its first image.png answer is held
    IMAGE_DELAY s in the browser (the server took the image when it answered) and its event
    stream opens EVENTS_DELAY s late, so tiles land after the image was taken and before the
    stream subscribed, and the stream's first `reload` comes while that image is still on its
    way. A page that skips that `reload` never shows those tiles until the render ends."""

    IMAGE_DELAY, EVENTS_DELAY = 1.0, 0.5
    PATTERNS = [{"urlPattern": "*/image.png*", "requestStage": "Response"},
                {"urlPattern": "*/events*", "requestStage": "Request"}]

    def __init__(self, page):
        self.page, self.held = page, set()

    def __call__(self, e):
        if e["method"] != "Fetch.requestPaused" or e.get("sessionId") != self.page.session:
            return
        p = e["params"]
        kind = "events" if "/events" in p["request"]["url"] else "image"
        delay = 0.0 if kind in self.held else {"events": self.EVENTS_DELAY, "image": self.IMAGE_DELAY}[kind]
        self.held.add(kind)

        def go():
            try:
                self.page.call("Fetch.continueRequest", requestId=p["requestId"], timeout=10)
            except devtools.DevToolsError:
                pass  # the page went away; the test says why
        threading.Timer(delay, go).start()


def wait(what, timeout, cond, step=0.1):
    deadline = time.monotonic() + timeout
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() > deadline:
            raise Fail("timed out after %g s waiting for %s" % (timeout, what))
        time.sleep(step)


class Capture:
    """One look at the page: a screenshot and, read at one moment, its numbers and canvas."""

    def __init__(self, page, shot_path):
        self.t0 = time.monotonic()
        r = page.evaluate(READ % "true", timeout=60)
        self.rgb = base64.b64decode(r.pop("rgb"))
        self.page = r
        data = base64.b64decode(page.call("Page.captureScreenshot", format="png", timeout=60)["data"])
        with open(shot_path, "wb") as f:
            f.write(data)
        self.shot = png.read(data)
        self.t1 = time.monotonic()


def fetch(address, path):
    """GET address + path (address: the page's URL, ending in / or carrying ?key=...)."""
    base, _, query = address.partition("?")
    with urllib.request.urlopen(base.rstrip("/") + "/" + path + ("?" + query if query else ""),
                                timeout=30) as r:
        return r.read()


def tiles_of(w, h):
    return [(x, y, min(TILE, w - x), min(TILE, h - y)) for y in range(0, h, TILE) for x in range(0, w, TILE)]


def drawn(rgb, w, tile):
    """Whether the canvas or frame `rgb` (w wide) has something drawn in `tile`."""
    x, y, tw, th = tile
    rows = [rgb[((y + j) * w + x) * 3:((y + j) * w + x + tw) * 3] for j in range(th)]
    return not any(all(r == u * tw for r in rows) for u in UNDRAWN)


def block_means(final, w, tile, s):
    """The tile of `final` (w wide) as the page draws it sent at scale s: each pixel the mean of
    its s x s block (aligned to the tile's corner, cut at its edges), rounded half up."""
    x, y, tw, th = tile
    out = []
    for j in range(th):
        by = j // s * s
        rows = range(y + by, y + min(by + s, th))
        row = []
        for i in range(tw):
            bx = i // s * s
            cols = range(x + bx, x + min(bx + s, tw))
            n = len(rows) * len(cols)
            for c in range(3):
                v = sum(final[(yy * w + xx) * 3 + c] for yy in rows for xx in cols)
                row.append((v + n // 2) // n)
        out.append(bytes(row))
    return out


def compare(rgb, final, w, h, scales=(1,)):
    """(tiles drawn and equal to the PNG's within TOLERANCE, tiles not drawn, tiles wrong,
    the largest channel difference in a drawn tile, tiles drawn as block means): a drawn tile
    is right if it equals the PNG's, or (for a scale s > 1 in `scales`) the PNG's s x s block
    means, within TOLERANCE."""
    good = undrawn = wrong = worst = coarse = 0
    for x, y, tw, th in tiles_of(w, h):
        rows = [((y + j) * w + x) * 3 for j in range(th)]
        mine = [rgb[o:o + tw * 3] for o in rows]
        if not drawn(rgb, w, (x, y, tw, th)):
            undrawn += 1
            continue
        best = None
        for s in scales:
            theirs = [final[o:o + tw * 3] for o in rows] if s == 1 else block_means(final, w, (x, y, tw, th), s)
            d = 0 if mine == theirs else max(abs(a - b) for m, t in zip(mine, theirs) for a, b in zip(m, t))
            if best is None or d < best[0]:
                best = (d, s)
            if d == 0:
                break
        d, s = best
        worst = max(worst, d)
        if d <= TOLERANCE:
            good += 1
            coarse += s > 1
        else:
            wrong += 1
    return good, undrawn, wrong, worst, coarse


def image_box(shot):
    """The image on the screenshot: the box inside the page's #333 frame (4 px wide), found as
    the first long run of frame colour down a column. (x0, y0, x1, y1) inclusive, inside it."""
    w, h, rgb = shot
    frame = b"\x33\x33\x33"
    px = lambda x, y: rgb[(y * w + x) * 3:(y * w + x) * 3 + 3]

    def run(cells):
        best, cur, start = (0, 0), 0, 0
        for i, p in enumerate(cells):
            if p == frame:
                start = i if cur == 0 else start
                cur += 1
                best = max(best, (cur, start))
            else:
                cur = 0
        return best

    for x0 in range(min(200, w)):
        length, y0 = run([px(x0, y) for y in range(h)])
        if length > 100:
            break
    else:
        raise Fail("no image frame on the screenshot")
    width, _ = run([px(x, y0) for x in range(x0, w)])
    return x0 + 4, y0 + 4, x0 + width - 5, y0 + length - 5


def shot_stats(shot):
    """(pixels in the image box, of them not drawn, box width, box height, mean RGB)."""
    w, _, rgb = shot
    x0, y0, x1, y1 = image_box(shot)
    n = undrawn = 0
    sums = [0, 0, 0]
    for y in range(y0, y1 + 1):
        row = rgb[(y * w + x0) * 3:(y * w + x1 + 1) * 3]
        for k in range(0, len(row), 3):
            p = row[k:k + 3]
            undrawn += p in UNDRAWN
        for c in range(3):
            sums[c] += sum(row[c::3])
        n += x1 - x0 + 1
    return n, undrawn, x1 - x0 + 1, y1 - y0 + 1, [s / n for s in sums]


def mean_rgb(rgb):
    n = len(rgb) // 3
    return [sum(rgb[c::3]) / n for c in range(3)]


def main():
    chrome, parrt, tmp = sys.argv[1:4]
    size = int(os.environ.get("LIVE_VIEW_SIZE", "768"))
    work = float(os.environ.get("LIVE_VIEW_WORK", "20"))
    shots = os.environ.get("LIVE_VIEW_SHOTS")
    rate = os.environ.get("LIVE_VIEW_FULL_RATE", "")
    broken = os.environ.get("LIVE_VIEW_BREAK", "")
    if broken and broken not in BREAKS:
        raise Fail("LIVE_VIEW_BREAK=%s: one of %s" % (broken, ", ".join(BREAKS)))
    if not 64 <= size <= 2048 or size % TILE:
        raise Fail("LIVE_VIEW_SIZE=%d: a multiple of %d from 64 to 2048" % (size, TILE))

    # Long enough to be caught twice mid-render whatever the build's speed: a calibration
    # render at one thread sizes the samples per pixel to about `work` seconds of one-thread
    # work (about half that on the two one-thread workers).
    spp = os.environ.get("LIVE_VIEW_SPP")
    if not spp:
        cal = subprocess.run([parrt, "render", "--scene", "mount:4", "--width", "96", "--height", "96",
                              "--spp", "4", "--threads", "1", "-o", tmp + "/cal.png",
                              "--stats-json", tmp + "/cal.json"], capture_output=True, timeout=120)
        if cal.returncode != 0:
            raise Fail("the calibration render failed: " + cal.stderr.decode(errors="replace"))
        t = max(json.load(open(tmp + "/cal.json"))["trace_s"], 1e-4) / 4
        spp = min(max(round(work * 96 * 96 / (size * size * t)), 1), 256)
        say("calibration: %.4f s a sample for 96x96; %d samples per pixel" % (t, int(spp)))
    spp = int(spp)
    say("image %dx%d, %d spp, %d-pixel tiles, %d one-thread workers%s%s"
        % (size, size, spp, TILE, WORKERS, ", page broken: " + broken if broken else "",
           ", --http-full-rate " + rate if rate else ""))
    total = len(tiles_of(size, size))
    out_png = tmp + "/out.png"

    watch = Watch()
    render = None
    with devtools.Browser(chrome, tmp + "/profile", tmp + "/chrome.log", WINDOW) as browser:
        browser.listen(watch)
        browser.keep = lambda e: e["method"] == "Page.loadEventFired"
        page = browser.new_page()
        for m in ("Page.enable", "Network.enable", "Runtime.enable"):
            page.call(m)
        browser.listen(SlowLink(page))
        page.call("Fetch.enable", patterns=SlowLink.PATTERNS)
        page.call("Emulation.setDeviceMetricsOverride", width=WINDOW[0], height=WINDOW[1],
                  deviceScaleFactor=1, mobile=False)
        if broken:
            page.call("Page.addScriptToEvaluateOnNewDocument", source=BREAKS[broken])
        try:
            render = Render(parrt, ["--scene", "mount:4", "--width", str(size), "--height", str(size),
                                    "--spp", str(spp), "--tile", str(TILE), "--workers", str(WORKERS),
                                    "--threads", "1", "--http", "127.0.0.1:0", "--http-linger", "300",
                                    "-o", out_png] + (["--http-full-rate", rate] if rate else []),
                            tmp + "/render.err")

            def url():
                if render.proc.poll() is not None:
                    raise Fail("parrt render ended early:\n" + "\n".join(render.lines))
                return render.line("parrt: live view at ")
            address = wait("parrt to print its address", 60, url)
            say("page at " + address)

            def started():
                if render.proc.poll() is not None:
                    raise Fail("parrt render ended early:\n" + "\n".join(render.lines))
                s = json.loads(fetch(address, "status"))
                if s["state"] not in ("starting", "rendering"):
                    raise Fail("the render was %s before the page was opened; raise LIVE_VIEW_WORK"
                               % s["state"])
                return s["tiles_done"] > 0
            wait("the first tiles", 60, started)
            loaded_from = time.monotonic()
            page.call("Page.navigate", url=address)
            if not browser.wait_event(lambda e: e["method"] == "Page.loadEventFired", 30, loaded_from):
                raise Fail("the page did not load in 30 s")

            def numbers():
                return page.evaluate(READ % "false")

            # 1: mid-render, the page's loads of the whole image over for 0.5 s, tiles arriving.
            def ready():
                p = numbers()
                if p["state"].startswith("done"):
                    raise Fail("the render ended before the page was caught mid-render "
                               "(%d/%d); raise LIVE_VIEW_WORK" % (p["done"], p["total"]))
                q = watch.quiet_since()
                return (p["state"] == "rendering" and p["done"] >= 0.05 * total and q is not None
                        and time.monotonic() - q > 0.5 and any(t > q for t in watch.tiles))
            wait("the page to count 5 % of the tiles done, its image loads over", 60, ready)
            frame_at_first = fetch(address, "frame")
            first = Capture(page, tmp + "/mid-1.png")
            say("capture 1: page says %(state)s %(done)d/%(total)d tiles, %(workers)d worker rows" % first.page
                + "; before it the page loaded image.png %d times, got %d reload events"
                % (len(watch.images), len(watch.reloads)))

            # 2: mid-render again, 10 % more tiles done by the page's count.
            def later():
                p = numbers()
                if p["state"].startswith("done"):
                    raise Fail("the render ended before the second capture (%d/%d at the first); "
                               "raise LIVE_VIEW_WORK" % (first.page["done"], total))
                return p["done"] >= first.page["done"] + math.ceil(0.1 * total) and \
                    time.monotonic() - first.t1 > 1.0
            wait("10 % more tiles on the page", 30 + 2 * work, later)
            second = Capture(page, tmp + "/mid-2.png")
            say("capture 2: page says %(state)s %(done)d/%(total)d tiles, %(workers)d worker rows" % second.page)
            n_tiles, n_reloads, n_loads = watch.between(first.t0, second.t1)

            # 3: the end, once parrt wrote its PNG and the page shows it.
            def written():
                if render.line("parrt: wrote "):
                    return True
                if render.proc.poll() is not None:
                    raise Fail("parrt ended without writing its PNG:\n" + "\n".join(render.lines))
            wait("the render to end and parrt to write its PNG", 60 + 6 * work, written)
            fw, fh, final = png.read(open(out_png, "rb").read())
            if (fw, fh) != (size, size):
                raise Fail("parrt wrote a %dx%d image" % (fw, fh))
            wait("the page to say done", 30, lambda: numbers()["state"].startswith("done"))

            def finished():
                p = page.evaluate(READ % "true", timeout=60)
                rgb = base64.b64decode(p["rgb"])
                return (p["width"], p["height"]) == (size, size) and compare(rgb, final, size, size)[0] == total
            try:
                wait("the page to show the whole image", 10, finished, step=0.5)
            except Fail as e:
                say(str(e) + " (checked below)")
            end = Capture(page, tmp + "/end.png")
            say("capture 3: page says %(state)s %(done)d/%(total)d tiles, %(workers)d worker rows" % end.page)
        finally:
            if render:
                render.end()

    failures = []
    mid_scales = (1, 2, 4, 8) if rate else (1,)
    coarse_seen = 0
    shown = min(size, round(0.55 * WINDOW[0]))  # the page caps the image at 55 % of the window
    counts = []
    for name, c in (("capture 1 (mid-render)", first), ("capture 2 (mid-render)", second)):
        p = c.page
        good, undrawn, wrong, worst, coarse = compare(c.rgb, final, size, size, mid_scales)
        n, blank, bw, bh, _ = shot_stats(c.shot)
        counts.append((good, blank))
        coarse_seen += coarse
        print("%s: canvas %dx%d: %d tiles drawn (%d as block means), %d not, %d wrong (largest "
              "difference %d); screenshot: image box %dx%d, %d/%d pixels not drawn"
              % (name, p["width"], p["height"], good, coarse, undrawn, wrong, worst, bw, bh, blank, n))
        check(p["state"] == "rendering" and 0 < p["done"] < p["total"] == total,
              "%s: the page says rendering, tiles between none and all" % name, failures)
        check(p["workers"] == WORKERS, "%s: one row per worker" % name, failures)
        check(abs(bw - shown) <= 0.03 * shown + 2 and abs(bh - shown) <= 0.03 * shown + 2,
              "%s: the image box is on the page at about its size" % name, failures)
        check(0 < good < total and 0.02 * n < blank < 0.98 * n,
              "%s: part of the image is drawn, part is not (canvas and screenshot)" % name, failures)
        check(wrong == 0, "%s: every tile drawn equals the PNG parrt wrote%s"
              % (name, " (or its block means)" if rate else ""), failures)
    held = [t for t in tiles_of(size, size) if not drawn(frame_at_first, size, t)]
    lost = [t for t in tiles_of(size, size) if drawn(frame_at_first, size, t) and not drawn(second.rgb, size, t)]
    print("tiles the server had at capture 1: %d; of them not drawn on the page at capture 2: %d %s"
          % (total - len(held), len(lost), [(x // TILE, y // TILE) for x, y, _, _ in lost[:12]]))
    check(not lost, "every tile the server had at capture 1 is drawn on the page at capture 2", failures)
    if rate:
        check(coarse_seen > 0, "mid-render, tiles are drawn as block means (the preview)", failures)
    print("between captures 1 and 2 (%.1f s): %d tiles events, %d reload events, %d loads of image.png"
          % (second.t1 - first.t0, n_tiles, n_reloads, n_loads))
    check(n_tiles > 0 and n_reloads == 0 and n_loads == 0,
          "between them the page got tiles events only (no reload, no image loaded)", failures)
    check(counts[1][0] > counts[0][0] and counts[1][1] < counts[0][1],
          "more of the image is drawn at capture 2 than at 1 (canvas tiles %d -> %d, screenshot "
          "pixels not drawn %d -> %d)" % (counts[0][0], counts[1][0], counts[0][1], counts[1][1]), failures)
    p = end.page
    good, undrawn, wrong, worst, _ = compare(end.rgb, final, size, size)
    n, blank, bw, bh, mean = shot_stats(end.shot)
    want = mean_rgb(final)
    print("capture 3 (end): canvas %dx%d: %d tiles equal the PNG, %d not drawn, %d wrong (largest "
          "difference %d); screenshot: image box %dx%d, %d/%d pixels not drawn, mean RGB %s (the "
          "PNG's %s)" % (p["width"], p["height"], good, undrawn, wrong, worst, bw, bh, blank, n,
                         "/".join("%.1f" % v for v in mean), "/".join("%.1f" % v for v in want)))
    check(p["state"].startswith("done") and p["done"] == p["total"] == total,
          "capture 3: the page says done, every tile", failures)
    check(p["workers"] == WORKERS, "capture 3: one row per worker", failures)
    check(good == total, "capture 3: every canvas tile equals the PNG parrt wrote", failures)
    check(blank < 0.002 * n and max(abs(a - b) for a, b in zip(mean, want)) <= SHOT_MEAN_TOLERANCE,
          "capture 3: the screenshot shows the whole image, its mean colour the PNG's", failures)

    if shots:
        os.makedirs(shots, exist_ok=True)
        for src, dst in (("mid-1", "mid-render"), ("mid-2", "mid-render-later"), ("end", "finished")):
            shutil.copy(tmp + "/" + src + ".png", shots + "/" + dst + ".png")
        say("screenshots kept in " + shots)
    if failures:
        raise Fail("%d check(s) failed" % len(failures))


if __name__ == "__main__":
    signal.signal(signal.SIGTERM, lambda *a: sys.exit("live-view: FAILED: terminated"))
    try:
        main()
    except (Fail, devtools.DevToolsError, OSError, ValueError, subprocess.TimeoutExpired) as e:
        print("live-view: FAILED: %s" % e, file=sys.stderr, flush=True)
        sys.exit(1)
    say("passed")
