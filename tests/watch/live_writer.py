"""A stand-in for the instrument software: a process that writes an export piece by piece in
real time (accelerated), for the tests that follow it with ``granflow watch``.

Run as ``python live_writer.py PLAN.json``: the plan is ``{"wait_for": LOG, "steps": [[delay
[s], action, path, data (base64)], ...]}``; the writer waits until the watch's log holds a
line (the watch is ready), then does each step at its delay from there: ``append`` bytes,
``truncate`` the file to nothing, ``replace`` it with another file's bytes (a new inode),
``create`` a new file, ``wait`` until a file (the log) holds a text (the watch has seen what
was written: the later steps keep their spacing from there). The module also makes plans
from exports (:func:`export_steps`).
"""

import base64
import json
import os
import sys
import time
from pathlib import Path

import numpy as np


def export_steps(path, dest, speed, *, offset=0.0, split_every=0, trailer=True):
    """Steps that write the export at ``path`` to ``dest`` as an instrument would: the header
    at once, each data row when its record time has come (``speed`` record seconds per
    second, from ``offset`` [s] of wall time); every ``split_every``-th row is written in two
    halves, a moment apart (a half-written line); ``trailer`` False leaves out what follows
    the last row (the block not yet closed). Returns (steps, row times, row lines)."""
    data = Path(path).read_bytes()
    encoding = "utf-16-le" if data[:2] == b"\xff\xfe" else "utf-8"
    body = data[2:] if encoding == "utf-16-le" else data
    lines = body.decode(encoding).split("\r\n")
    steps, times, numbers = [], [], []
    header = []
    delay = offset
    for number, line in enumerate(lines, start=1):
        cells = line.split("\t")
        is_row = len(cells) > 2 and cells[0] == "" and cells[1].strip().isdigit()
        text = line + ("\r\n" if number < len(lines) else "")
        if not is_row:
            header.append(text)
            continue
        if header:
            steps.append([delay, "append", str(dest), _encode("".join(header), encoding)])
            header = []
        row_time = float(cells[2])
        delay = max(offset + row_time / speed, delay)
        times.append(row_time)
        numbers.append(number)
        if split_every and len(times) % split_every == 0:
            half = len(text) // 2
            steps.append([delay, "append", str(dest), _encode(text[:half], encoding)])
            steps.append([delay + 0.3, "append", str(dest), _encode(text[half:], encoding)])
            delay += 0.3
        else:
            steps.append([delay, "append", str(dest), _encode(text, encoding)])
    if header and trailer:
        steps.append([delay, "append", str(dest), _encode("".join(header), encoding)])
    if encoding == "utf-16-le":
        steps.insert(0, [offset, "append", str(dest), base64.b64encode(b"\xff\xfe").decode()])
    return steps, np.array(times), numbers


def _encode(text, encoding):
    return base64.b64encode(text.encode(encoding)).decode()


def write_plan(path, steps, wait_for):
    """Save a plan for the writer process."""
    Path(path).write_text(json.dumps({"wait_for": str(wait_for), "steps": steps}))


def main(plan_path):
    plan = json.loads(Path(plan_path).read_text())
    log = Path(plan["wait_for"])
    deadline = time.monotonic() + 120
    while not (log.exists() and log.stat().st_size) and time.monotonic() < deadline:
        time.sleep(0.05)
    start = time.monotonic()
    deadline = start + 300
    for delay, action, target, data in sorted(plan["steps"], key=lambda step: step[0]):
        pause = start + delay - time.monotonic()
        if pause > 0:
            time.sleep(pause)
        target = Path(target)
        payload = base64.b64decode(data) if data else b""
        if action == "append":
            with target.open("ab") as stream:
                stream.write(payload)
                stream.flush()
                os.fsync(stream.fileno())
        elif action == "truncate":
            with target.open("wb"):
                pass
        elif action == "replace":
            fresh = target.with_name(target.name + ".new")
            fresh.write_bytes(payload)
            fresh.replace(target)
        elif action == "create":
            target.write_bytes(payload)
        elif action == "wait":
            while payload not in (target.read_bytes() if target.exists() else b""):
                if time.monotonic() > deadline:
                    return 1
                time.sleep(0.05)
            start = time.monotonic() - delay
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
