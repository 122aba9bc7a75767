#!/usr/bin/env python3
"""Evicts a dataset's face files from the page cache every INTERVAL seconds for SECONDS seconds
(posix_fadvise DONTNEED): deterministic stand-in for other processes' memory pressure, to fly a
no-stall bench beside. Pages a process has mapped with page-table entries stay (the bench drops
its own each frame).

  bench/evict_every.py DATASET_DIR SECONDS [INTERVAL]
e.g. bench/evict_every.py build/large/mars_16384_pv512 400 & \\
     build/release/tools/pbdam bench build/large/mars_16384_pv512 \\
       --path bench/paths/mars_flight.csv --out /tmp/evicted --cold --width 1280 --height 720 \\
       --mode no-stall --prefetch off --quiet; kill %1
"""
import glob
import os
import sys
import time

if len(sys.argv) not in (3, 4):
    sys.exit(__doc__)
files = sorted(glob.glob(os.path.join(sys.argv[1], "face*.pbdam")))
if not files:
    sys.exit(f"evict_every: no face files in {sys.argv[1]}")
interval = float(sys.argv[3]) if len(sys.argv) == 4 else 1.0
end = time.time() + float(sys.argv[2])
rounds = 0
while time.time() < end:
    for name in files:
        fd = os.open(name, os.O_RDONLY)
        os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
        os.close(fd)
    rounds += 1
    time.sleep(interval)
print(f"evict_every: {rounds} rounds")
