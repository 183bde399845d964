#!/usr/bin/env python3
"""Drives a booting kiosk image through QEMU's QMP socket; called by deploy/test-image.sh.

Waits for `volasso: ready WxH` on the serial log, screendumps the UI, taps it through
input-send-event (the virtio tablet), screendumps until the screen changes, then presses the
console's escape keys (Ctrl-Alt-F2, Alt-F2, Ctrl-Alt-Del) and checks the UI stays. Writes
PNG screenshots to --out. Last, it hot-plugs the USB stick QEMU holds as drive `stick` and
waits for the import's summary line and for the imported volumes' cards in the chooser. With
--dicom-port and --dicom-series it pushes a DICOM series to the guest's receiver with storescu
and waits for its stored line and its card. Then it opens the demo's card and waits for the
work screen. What a user does by touch is in --touch-dir (deploy/touch/*.touch), compiled on the
host by --binary (`volasso replay --events-out`, at the guest's size and density read from its
console) and played through the tablet with its timing (`# wait-idle` waits for the screen to
settle, `# screenshot NAME` screendumps); their `expect element` lines say where the 3-D view and
the cards are. Before the tap it visits the settings screen (a long press on the title, a PIN
chosen twice, Done); after the push it opens the series from its card (named by description,
modality and images on the console); after the demo opens it draws two loops, and the 3-D view
must show two hues. Exits non-zero with the reason on stderr when a check fails.
Standard library only (runs on the bare host).
"""

import argparse
import json
import os
import re
import socket
import struct
import subprocess
import sys
import time
import zlib

READY = re.compile(rb"volasso: ready (\d+)x(\d+)")
IMPORTED = re.compile(rb"volasso-import: (\d+) imported, (\d+) skipped")
# The DICOM receiver's JSON line for a stored series (volasso-receive.service, on the console).
STORED = re.compile(rb'\{"event":"stored","name":"[A-Z0-9]+-[0-9a-f]{16}"[^\n]*')
TABLET_MAX = 0x7FFF  # QEMU's absolute axis range for input-send-event
# The kiosk's journal lines (volasso.service, on the console).
SETTINGS_OPEN = re.compile(rb"settings screen: open \(the PIN was accepted\)")
SETTINGS_CLOSED = re.compile(rb"settings screen: closed")
DEMO_CARD = re.compile(rb'card 1: "Demo: CT foot phantom" with a \d+x\d+ thumbnail')
SERIES_CARD = re.compile(rb'card (\d+): "([^"\n]*\(CT, (\d+) images\))" with a (\d+)x(\d+) thumbnail')
DPI = re.compile(rb"UI at (\d+) dpi")


class Qmp:
    def __init__(self, path, deadline, qemu_pid):
        while True:
            if not alive(qemu_pid):
                fail("QEMU exited before its QMP socket answered")
            try:
                self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                self.sock.connect(path)
                break
            except OSError:
                if time.time() > deadline:
                    raise
                time.sleep(0.2)
        self.reader = self.sock.makefile("rb")
        json.loads(self.reader.readline())  # greeting
        self.command("qmp_capabilities")

    def command(self, name, **arguments):
        self.sock.sendall(json.dumps({"execute": name, "arguments": arguments}).encode() + b"\n")
        while True:
            reply = json.loads(self.reader.readline())
            if "return" in reply:
                return reply["return"]
            if "error" in reply:
                raise RuntimeError(f"QMP {name}: {reply['error']}")
            # asynchronous events (RESET, SHUTDOWN...) are skipped


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def read_ppm(path):
    with open(path, "rb") as ppm:
        data = ppm.read()
    fields = data.split(maxsplit=4)
    if fields[0] != b"P6" or fields[3] != b"255":
        raise RuntimeError(f"unexpected screendump format in {path}")
    width, height = int(fields[1]), int(fields[2])
    pixels = fields[4][: width * height * 3]
    return width, height, pixels


def write_png(path, width, height, pixels):
    rows = b"".join(b"\x00" + pixels[y * width * 3 : (y + 1) * width * 3] for y in range(height))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    with open(path, "wb") as png:
        png.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows, 6)) + chunk(b"IEND", b""))


def screenshot(qmp, out, name):
    ppm = f"{out}/{name}.ppm"
    qmp.command("screendump", filename=ppm)
    width, height, pixels = read_ppm(ppm)
    write_png(f"{out}/{name}.png", width, height, pixels)
    os.remove(ppm)
    return width, height, pixels


def lit_fraction(pixels):
    """Share of pixels that are not pure black."""
    count = len(pixels) // 3
    black = sum(1 for i in range(0, len(pixels), 3) if pixels[i : i + 3] == b"\x00\x00\x00")
    return 1 - black / count


def changed_fraction(first, second):
    count = len(first) // 3
    changed = sum(1 for i in range(0, len(first), 3) if first[i : i + 3] != second[i : i + 3])
    return changed / count


def fail(message, serial=None):
    print(f"FAIL: {message}", file=sys.stderr)
    if serial:
        with open(serial, "rb") as log:
            tail = log.read().decode(errors="replace").splitlines()[-40:]
        print("--- last serial lines ---\n" + "\n".join(tail), file=sys.stderr)
    sys.exit(1)


def tap(qmp, x_fraction, y_fraction):
    x, y = round(x_fraction * TABLET_MAX), round(y_fraction * TABLET_MAX)
    position = [{"type": "abs", "data": {"axis": "x", "value": x}}, {"type": "abs", "data": {"axis": "y", "value": y}}]
    qmp.command("input-send-event", events=position)
    time.sleep(0.1)
    qmp.command("input-send-event", events=position + [{"type": "btn", "data": {"down": True, "button": "left"}}])
    time.sleep(0.15)
    qmp.command("input-send-event", events=[{"type": "btn", "data": {"down": False, "button": "left"}}])


def play(qmp, path, out, serial):
    """Plays a `volasso-events/1` recording through the tablet: each SYN_REPORT sends the
    finger's position and touch state, paced as recorded; `# wait-idle` waits for the screen to
    settle (the pacing starts again after it) and `# screenshot NAME` screendumps NAME."""
    ranges = {"x": (0, TABLET_MAX), "y": (0, TABLET_MAX)}
    position, sent, touching, was_touching = [0, 0], None, False, False
    base = None
    with open(path) as recording:
        lines = recording.read().splitlines()
    for line in lines:
        if line.startswith("# wait-idle"):
            wait_until_stable(qmp, out, "idle", 120)
            base = None
            continue
        if line.startswith("# screenshot "):
            screenshot(qmp, out, line.split(" ", 2)[2].strip())
            base = None
            continue
        if line.startswith("#") or not line.strip():
            continue
        words = line.split()
        if words[0] in ("x:", "y:"):
            ranges[words[0][0]] = (int(words[1]), int(words[2]))
            continue
        if len(words) != 4 or not words[0][0].isdigit():
            continue
        at, kind, code, value = float(words[0]), words[1], words[2], int(words[3])
        if kind == "EV_ABS" and code in ("ABS_MT_POSITION_X", "ABS_X"):
            position[0] = value
        elif kind == "EV_ABS" and code in ("ABS_MT_POSITION_Y", "ABS_Y"):
            position[1] = value
        elif kind == "EV_KEY" and code == "BTN_TOUCH":
            touching = value == 1
        elif kind == "EV_SYN" and code == "SYN_REPORT":
            now = time.time()
            if base is None:
                base = (now, at)
            delay = base[0] + (at - base[1]) - now
            if delay > 0:
                time.sleep(delay)
            scaled = [round((position[i] - ranges[axis][0]) * TABLET_MAX / max(1, ranges[axis][1] - ranges[axis][0]))
                      for i, axis in enumerate("xy")]
            events = []
            if scaled != sent:
                events += [{"type": "abs", "data": {"axis": "x", "value": scaled[0]}},
                           {"type": "abs", "data": {"axis": "y", "value": scaled[1]}}]
                sent = scaled
            if touching != was_touching:
                events.append({"type": "btn", "data": {"down": touching, "button": "left"}})
                was_touching = touching
            if events:
                qmp.command("input-send-event", events=events)
    if was_touching:
        qmp.command("input-send-event", events=[{"type": "btn", "data": {"down": False, "button": "left"}}])


def serial_text(serial):
    with open(serial, "rb") as log:
        return log.read()


def wait_for_line(pattern, serial, seconds):
    """The first match of `pattern` on the serial log within `seconds`, or None."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        found = pattern.search(serial_text(serial))
        if found:
            return found
        time.sleep(1)
    return None


def compile_touches(arguments, name, size, dpi, *extra):
    """Runs deploy/touch/NAME.touch through the same UI on the host at the guest's screen size
    and density (--binary, the image's own): its events as a recording to play, and the report
    (with the rectangles its `expect element` lines found)."""
    events = os.path.join(arguments.out, f"{name}.events")
    ran = subprocess.run([arguments.binary, "replay", os.path.join(arguments.touch_dir, f"{name}.touch"),
                          "--size", f"{size[0]}x{size[1]}", "--dpi", str(dpi), "--events-out", events, *extra],
                         capture_output=True, timeout=300)
    lines = ran.stdout.decode(errors="replace").strip().splitlines()
    if ran.returncode != 0 or not lines:
        fail(f"{name}.touch fails on the host: {ran.stdout.decode(errors='replace')}{ran.stderr.decode(errors='replace')}")
    return events, json.loads(lines[-1])


def hues_in_view(pixels, width, height, view):
    """Hues (12 bins of 30 degrees) held by at least 0.2 % of the 3-D view's pixels (`view`:
    x, y, width, height) that are coloured: bright enough and saturated (the rule of
    `expect view-colours`)."""
    x0, y0 = max(0, int(view[0])), max(0, int(view[1]))
    x1, y1 = min(width, int(view[0] + view[2])), min(height, int(view[1] + view[3]))
    bins, count = [0] * 12, 0
    for y in range(y0, y1):
        row = pixels[3 * y * width:3 * (y + 1) * width]
        for x in range(x0, x1):
            r, g, b = row[3 * x:3 * x + 3]
            count += 1
            high, low = max(r, g, b), min(r, g, b)
            if high < 64 or (high - low) / high < 0.25:
                continue
            if high == r:
                hue = 60 * (((g - b) / (high - low)) % 6)
            elif high == g:
                hue = 60 * ((b - r) / (high - low) + 2)
            else:
                hue = 60 * ((r - g) / (high - low) + 4)
            bins[min(11, int(hue // 30))] += 1
    return sum(1 for n in bins if n >= max(1, count // 500))


def centre(rect, width, height):
    """The middle of `rect` (x, y, width, height in pixels) as fractions of the screen."""
    return (rect[0] + rect[2] / 2) / width, (rect[1] + rect[3] / 2) / height


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--qemu-pid", type=int, required=True)
    parser.add_argument("--qmp", required=True)
    parser.add_argument("--serial", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--started", type=float, required=True, help="time QEMU was started (epoch seconds)")
    parser.add_argument("--timeout", type=float, default=300)
    parser.add_argument("--stick-volumes", type=int, required=True, help="volumes on the VOLASSO stick")
    parser.add_argument("--tap", default="0.5,0.5", help="where to tap, as fractions of width,height")
    parser.add_argument("--dicom-port", type=int, help="host port forwarded to the guest's DICOM receiver")
    parser.add_argument("--dicom-series", help="a DICOM series folder to push with dcmtk's storescu")
    parser.add_argument("--binary", required=True, help="the image's volasso, to compile the touches on the host")
    parser.add_argument("--touch-dir", required=True, help="deploy/touch: what a user does, as touch scripts")
    arguments = parser.parse_args()
    deadline = arguments.started + arguments.timeout
    qmp = Qmp(arguments.qmp, deadline, arguments.qemu_pid)

    match = None
    while match is None:
        if time.time() > deadline:
            fail(f"no ready line within {arguments.timeout:.0f} s", arguments.serial)
        try:
            with open(arguments.serial, "rb") as log:
                match = READY.search(log.read())
        except FileNotFoundError:
            pass
        if match is None:
            if not alive(arguments.qemu_pid):
                fail("QEMU exited before the ready line", arguments.serial)
            status = qmp.command("query-status")
            if status.get("status") not in ("running", "prelaunch"):
                fail(f"QEMU stopped ({status.get('status')}) before the ready line", arguments.serial)
            time.sleep(0.25)
    boot_to_ready = time.time() - arguments.started
    print(f"boot-to-ready: {boot_to_ready:.1f} s (QEMU start to `{match.group(0).decode()}` on serial)")

    width, height, before = screenshot(qmp, arguments.out, "1-ready")
    lit = lit_fraction(before)
    print(f"screendump {width}x{height}: {lit:.1%} of pixels lit")
    if lit < 0.01:
        fail("the screen is blank after the ready line", arguments.serial)

    # What a user does, compiled on the host at the guest's size and density.
    size = (int(match.group(1)), int(match.group(2)))
    density = DPI.search(serial_text(arguments.serial))
    dpi = int(density.group(1)) if density else 150
    host_data = os.path.join(arguments.out, "host-data")
    os.makedirs(host_data, exist_ok=True)
    settings_events, _ = compile_touches(arguments, "settings-pin", size, dpi, "--data-dir", host_data)
    loops_events, loops = compile_touches(arguments, "two-loops", size, dpi, "--volume", "demo")
    grid = os.path.join(arguments.out, "card-grid")
    os.makedirs(grid, exist_ok=True)
    for name in ("a.nrrd", "b.nrrd", "c.nrrd"):
        with open(os.path.join(grid, name), "wb") as volume:
            volume.write(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n\n" + bytes(range(1, 9)))
    _, cards = compile_touches(arguments, "card-grid", size, dpi, "--data-dir", grid)
    card_rects = [cards["elements"][name] for name in ("Demo: CT foot phantom", "a.nrrd", "b.nrrd", "c.nrrd")]
    print(f"touches compiled on the host at {size[0]}x{size[1]}, {dpi} dpi")

    # The settings screen, reached as a user reaches it: a long press on the title and a PIN.
    play(qmp, settings_events, arguments.out, arguments.serial)
    text = serial_text(arguments.serial)
    if not SETTINGS_OPEN.search(text) or not SETTINGS_CLOSED.search(text):
        fail("the long press and the PIN did not open and close the settings screen", arguments.serial)
    print("settings: a long press on the title, a PIN chosen twice, the settings screen, Done")
    _, _, before = screenshot(qmp, arguments.out, "1b-start-again")

    x_fraction, y_fraction = (float(value) for value in arguments.tap.split(","))
    tap_time = time.time()
    tap(qmp, x_fraction, y_fraction)
    changed = 0.0
    while time.time() < tap_time + 30:
        time.sleep(1)
        _, _, after = screenshot(qmp, arguments.out, "2-after-tap")
        changed = changed_fraction(before, after)
        if changed > 0.0005:
            break
    print(f"tap at ({x_fraction}, {y_fraction}): {changed:.2%} of pixels changed after {time.time() - tap_time:.1f} s")
    if changed <= 0.0005:
        fail("the UI did not react to the tap", arguments.serial)

    # Lockdown: the console's own escapes must not take the screen away or reboot the guest.
    # Thumbnails load on a thread: wait for the demo's (the console says when it is shown), then
    # until two screendumps 2 s apart agree.
    if wait_for_line(DEMO_CARD, arguments.serial, 90) is None:
        fail("the demo's card got no thumbnail within 90 s", arguments.serial)
    settled = wait_until_stable(qmp, arguments.out, "3-settled", 90)
    for keys in (["ctrl", "alt", "f2"], ["alt", "f2"], ["ctrl", "alt", "delete"], ["alt", "right"]):
        qmp.command("send-key", keys=[{"type": "qcode", "data": key} for key in keys])
        time.sleep(0.5)
    time.sleep(3)
    _, _, escaped = screenshot(qmp, arguments.out, "4-after-escape-keys")
    left = changed_fraction(settled, escaped)
    status = qmp.command("query-status")
    with open(arguments.serial, "rb") as log:
        ready_lines = len(READY.findall(log.read()))
    print(f"after Ctrl-Alt-F2, Alt-F2, Ctrl-Alt-Del, Alt-Right: {left:.2%} of pixels changed, "
          f"guest {status.get('status')}, {ready_lines} ready line(s)")
    if status.get("status") != "running" or ready_lines != 1 or left > 0.02:
        fail("a console key combination left or restarted the kiosk", arguments.serial)

    # New volumes: plug in a USB stick labelled VOLASSO and wait for the import's summary line.
    plugged = time.time()
    qmp.command("device_add", driver="usb-storage", bus="xhci.0", drive="stick", id="stick-device")
    imported = None
    while imported is None and time.time() < plugged + 90:
        time.sleep(1)
        with open(arguments.serial, "rb") as log:
            imported = IMPORTED.search(log.read())
    if imported is None:
        fail("plugging in the VOLASSO stick imported nothing within 90 s", arguments.serial)
    print(f"USB stick: `{imported.group(0).decode()}` {time.time() - plugged:.1f} s after plugging in")
    if int(imported.group(1)) != arguments.stick_volumes:
        fail(f"expected {arguments.stick_volumes} imported volumes", arguments.serial)
    # The chooser lists the data folder again every 2 s: the new cards must appear.
    shown = wait_for_change(qmp, arguments.out, "5-imported-volumes", escaped, 30)
    if shown is None:
        fail("the imported volumes did not appear in the chooser within 30 s", arguments.serial)
    print(f"chooser: the imported volumes' cards appeared {time.time() - plugged:.1f} s after plugging in")

    if arguments.dicom_port and arguments.dicom_series:
        shown = push_dicom_series(qmp, arguments, shown)
        card = wait_for_line(SERIES_CARD, arguments.serial, 60)
        if card is None:
            fail("the received series' card was not named by description, modality and images "
                 "with a thumbnail within 60 s", arguments.serial)
        print(f"chooser: card {card.group(1).decode()} is `{card.group(2).decode()}` "
              f"with a {card.group(4).decode()}x{card.group(5).decode()} thumbnail")
        shown = wait_until_stable(qmp, arguments.out, "5c-series-card", 30)
        number = int(card.group(1))
        if number > len(card_rects):
            fail(f"the series' card is number {number}; the test knows where the first {len(card_rects)} are")
        tap(qmp, *centre(card_rects[number - 1], *size))
        series = wait_for_change(qmp, arguments.out, "5d-series-open", shown, 90)
        if series is None:
            fail("tapping the received series' card did not open it within 90 s", arguments.serial)
        wait_until_stable(qmp, arguments.out, "5d-series-open", 60)
        print("work screen: the received series opened from its card")
        tap(qmp, *centre(loops["elements"]["Volumes"], *size))  # back to the chooser
        shown = wait_until_stable(qmp, arguments.out, "5e-chooser-again", 30)

    # The demo's card (the first) opens the work screen: slices, class bar, 3-D view.
    tap(qmp, *centre(card_rects[0], *size))
    opened = time.time()
    work = wait_for_change(qmp, arguments.out, "6-work-screen", shown, 90)
    if work is None:
        fail("tapping the demo's card did not open the work screen within 90 s", arguments.serial)
    time.sleep(5)
    screenshot(qmp, arguments.out, "7-work-screen-settled")
    print(f"demo card: the work screen appeared {time.time() - opened - 5:.1f} s after the tap")
    # Two loops by touch on the demo, each a class: the 3-D view shows both hues.
    play(qmp, loops_events, arguments.out, arguments.serial)
    drawn = time.time()
    hues = 0
    while hues < 2 and time.time() < drawn + 180:
        width, height, pixels = screenshot(qmp, arguments.out, "8-two-classes")
        hues = hues_in_view(pixels, width, height, loops["elements"]["view"])
        if hues < 2:
            time.sleep(3)
    print(f"two loops drawn: the 3-D view shows {hues} hues {time.time() - drawn:.1f} s after the last loop")
    if hues < 2:
        fail("after two loops the 3-D view does not show two classes' colours", arguments.serial)
    print("PASS: UI up, the settings screen through a long press and a PIN, reacts to a tap, stays through "
          "the console's escape keys, imports a USB stick whose volumes appear in the chooser, opens a pushed "
          "series from its card, opens the demo and shows two loops' classes in colour in 3-D")


def push_dicom_series(qmp, arguments, before):
    """Sends a series to the guest's DICOM receiver (storescu through QEMU's port forward),
    waits for its `"event":"stored"` line on the serial console and for its card in the chooser;
    the chooser's pixels then."""
    files = sorted(os.path.join(arguments.dicom_series, name) for name in os.listdir(arguments.dicom_series)
                   if name != "DIRFILE")
    pushed = time.time()
    sent = subprocess.run(["storescu", "-aec", "VOLASSO", "127.0.0.1", str(arguments.dicom_port), *files],
                          capture_output=True, timeout=120)
    if sent.returncode != 0:
        fail(f"storescu into the guest failed: {sent.stderr.decode(errors='replace')}", arguments.serial)
    stored = None
    while stored is None and time.time() < pushed + 120:
        time.sleep(1)
        with open(arguments.serial, "rb") as log:
            stored = STORED.search(log.read())
    if stored is None:
        fail("the pushed series was not stored within 120 s", arguments.serial)
    print(f"DICOM: {len(files)} files sent, `{stored.group(0).decode()[:120]}` {time.time() - pushed:.1f} s after the push")
    shown = wait_for_change(qmp, arguments.out, "5b-received-series", before, 30)
    if shown is None:
        fail("the received series did not appear in the chooser within 30 s", arguments.serial)
    print(f"chooser: the received series' card appeared {time.time() - pushed:.1f} s after the push")
    return shown


def wait_until_stable(qmp, out, name, seconds):
    """Screendumps every 2 s until two in a row agree (or `seconds` pass); the last pixels."""
    _, _, previous = screenshot(qmp, out, name)
    deadline = time.time() + seconds
    while time.time() < deadline:
        time.sleep(2)
        _, _, now = screenshot(qmp, out, name)
        if now == previous:
            return now
        previous = now
    return previous


def wait_for_change(qmp, out, name, before, seconds):
    """Screendumps every second until the screen differs from `before` by more than 0.05 % of
    its pixels; the pixels then, or None after `seconds`."""
    deadline = time.time() + seconds
    while time.time() < deadline:
        time.sleep(1)
        _, _, now = screenshot(qmp, out, name)
        if changed_fraction(before, now) > 0.0005:
            return now
    return None


if __name__ == "__main__":
    main()
