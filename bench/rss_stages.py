#!/usr/bin/env python3
"""Peak resident memory of a command by stage of its progress output.

    bench/rss_stages.py [--interval S] [--json FILE] -- COMMAND [ARGS...]

Runs COMMAND, reads its progress lines (stderr and stdout; `pbdam build` prints "resample 41%",
"simplify 3%", "textures 10%", "assemble 50%" ... when its output is not a terminal) and samples
/proc/PID/status every S seconds (default 0.1): VmRSS, RssAnon (heap, stacks: what the kernel
cannot drop), RssFile (mapped file pages) and RssShmem. The stage of a sample is the first word
of the last progress line read before it. Prints one row per stage, in the order they began, with
its duration and the peaks of each figure inside it, then the whole run's; --json writes the same
for scripts. Exits with the command's exit status.
"""
import json
import os
import subprocess
import sys
import threading
import time


def status(pid):
    fields = {}
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("VmRSS", "RssAnon", "RssFile", "RssShmem"):
                    fields[key] = int(value.split()[0]) * 1024
    except (FileNotFoundError, ProcessLookupError):
        return None
    return fields


def main(argv):
    interval = 0.1
    json_out = None
    args = argv[1:]
    while args and args[0] != "--":
        if args[0] == "--interval" and len(args) > 1:
            interval = float(args[1])
            args = args[2:]
        elif args[0] == "--json" and len(args) > 1:
            json_out = args[1]
            args = args[2:]
        elif args[0] in ("-h", "--help"):
            print(__doc__)
            return 0
        else:
            print(f"rss_stages: unknown option {args[0]!r} (see --help)", file=sys.stderr)
            return 2
    if not args or len(args) < 2:
        print("rss_stages: give the command after --", file=sys.stderr)
        return 2
    proc = subprocess.Popen(args[1:], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, errors="replace")
    stage = ["start"]
    lock = threading.Lock()
    tail = []

    def reader():
        for line in proc.stdout:
            words = line.split()
            tail.append(line.rstrip("\n"))
            del tail[:-20]
            if words and words[0][0].isalpha():
                with lock:
                    stage[0] = words[0].rstrip(":")

    t = threading.Thread(target=reader, daemon=True)
    t.start()
    keys = ("VmRSS", "RssAnon", "RssFile", "RssShmem")
    stages = {}
    order = []
    start = time.monotonic()
    while proc.poll() is None:
        s = status(proc.pid)
        now = time.monotonic() - start
        if s:
            with lock:
                name = stage[0]
            if name not in stages:
                stages[name] = {"begin_s": now, "end_s": now, **{k: 0 for k in keys}}
                order.append(name)
            row = stages[name]
            row["end_s"] = now
            for k in keys:
                row[k] = max(row[k], s.get(k, 0))
        time.sleep(interval)
    t.join(timeout=5)
    total = {k: max((stages[n][k] for n in order), default=0) for k in keys}
    mib = 1 << 20
    print(f"{'stage':<14}{'seconds':>9}{'RSS MiB':>10}{'anon MiB':>10}{'file MiB':>10}"
          f"{'shmem MiB':>11}")
    for n in order + ["(whole run)"]:
        row = stages[n] if n in stages else {"begin_s": 0.0,
                                             "end_s": time.monotonic() - start, **total}
        print(f"{n:<14}{row['end_s'] - row['begin_s']:>9.1f}{row['VmRSS'] / mib:>10.0f}"
              f"{row['RssAnon'] / mib:>10.0f}{row['RssFile'] / mib:>10.0f}"
              f"{row['RssShmem'] / mib:>11.0f}")
    if proc.returncode != 0:
        print("rss_stages: the command failed; its last lines:", file=sys.stderr)
        for line in tail:
            print("  " + line, file=sys.stderr)
    if json_out:
        with open(json_out, "w") as f:
            json.dump({"command": args[1:], "exit": proc.returncode,
                       "stages": [{"stage": n, **stages[n]} for n in order],
                       "peak": total}, f, indent=1)
    return proc.returncode


if __name__ == "__main__":
    sys.exit(main(sys.argv))
