#!/usr/bin/python3
"""The image archive under load (docs/commissioning.md "Archive: measured").

The simulated cell (vgr-sim-camera, vgrd, vgr-sim-plc) with every 10th frame an empty
belt (NO_PART_FOUND), a PLC triggering at ~5 Hz, run in alternating blocks with the
archive on (quota 20 MB, every 100th good frame) and off, so the machine's load (shared,
noisy) falls on both alike. The archive blocks share one journal and one archive folder:
together they are the 10-minute run of the issue (with a vgrd restart between blocks).

Reports, per mode: cycles, rate, trigger -> RESULT_VALID as the PLC sees it (p50, p99),
the journal's total_ms (p50, p99), vgrd's CPU time per cycle; for the archive: the
folder's peak and final size against the quota, frames written / dropped / deleted, and
whether every failed cycle of the last quota's worth is in the archive and named by its
journal line.

    ip netns exec vgr-NAME /usr/bin/python3 bench/archive_bench.py --bin build/bin \\
        --blocks 5 --block-minutes 2 --out /tmp/archive-bench.json
"""
import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def pct(values, p):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(round(p / 100.0 * (len(v) - 1))))]


def folder_bytes(path):
    total = 0
    try:
        for name in os.listdir(path):
            if not name.endswith(".tmp"):
                try:
                    total += os.path.getsize(os.path.join(path, name))
                except OSError:
                    pass
    except OSError:
        pass
    return total


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def wait_for(path, needle, timeout):
    end = time.time() + timeout
    while time.time() < end:
        try:
            with open(path) as f:
                if needle in f.read():
                    return True
        except OSError:
            pass
        time.sleep(0.05)
    return False


def run_block(args, work, mode, seconds, journal, archive, block):
    cfg = os.path.join(work, f"cell-{mode}.yaml")
    with open(os.path.join(ROOT, "config/examples/sim-cell.yaml")) as f:
        yaml = f.read()
    if mode == "archive":
        yaml += f"\narchive:\n  dir: {archive}\n  quota_mb: {args.quota_mb}\n  every_nth_good: {args.every_nth_good}\n"
    with open(cfg, "w") as f:
        f.write(yaml)
    shutil.copytree(os.path.join(ROOT, "config/examples/sim-calib"), os.path.join(work, "sim-calib"), dirs_exist_ok=True)
    log = open(os.path.join(work, f"{mode}.log"), "a")
    cam = subprocess.Popen([os.path.join(args.bin, "vgr-sim-camera"), "--config", cfg, "--empty-every", str(args.empty_every)],
                           stdout=subprocess.PIPE, stderr=log, text=True)
    cam.stdout.readline()  # its ready line
    vlog = os.path.join(work, f"vgrd-{mode}-{block}.log")  # one per start: "ready" is this start's
    vgrd = subprocess.Popen([os.path.join(args.bin, "vgrd"), "--config", cfg, "--journal", journal], stdout=log,
                            stderr=open(vlog, "a"))
    if not wait_for(vlog, "ready: camera streaming", 30):
        raise SystemExit(f"vgrd did not come up: {vlog}")
    cycles = max(1, int(seconds * args.rate_hz))
    cpu0 = cpu_seconds(vgrd.pid)
    peak = [0]
    stop = threading.Event()

    def sample():
        while not stop.is_set():
            peak[0] = max(peak[0], folder_bytes(archive))
            time.sleep(0.2)

    sampler = threading.Thread(target=sample)
    sampler.start()
    t0 = time.time()
    plc = subprocess.run([os.path.join(args.bin, "vgr-sim-plc"), "--cycles", str(cycles), "--interval-ms",
                          str(args.interval_ms), "--json", "--timeout-ms", "3000"], capture_output=True, text=True)
    elapsed = time.time() - t0
    time.sleep(1.0)  # the archive writes what is queued
    cpu1 = cpu_seconds(vgrd.pid)
    stop.set()
    sampler.join()
    peak[0] = max(peak[0], folder_bytes(archive))
    vgrd.send_signal(signal.SIGTERM)
    vgrd.wait(timeout=20)
    cam.send_signal(signal.SIGTERM)
    cam.wait(timeout=20)
    lat = [json.loads(l)["latency_ms"] for l in plc.stdout.splitlines() if l.startswith("{") and "latency_ms" in l]
    if not lat:
        raise SystemExit(f"block {block} {mode}: the PLC got no result: {plc.stdout[-500:]} {plc.stderr[-500:]}")
    return {"cycles": cycles, "answered": len(lat), "elapsed_s": elapsed, "plc_latency_ms": lat,
            "cpu_s": cpu1 - cpu0, "peak_bytes": peak[0]}


def journal_lines(path):
    out = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line:
                out.append(json.loads(line))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/bin"))
    ap.add_argument("--blocks", type=int, default=5)
    ap.add_argument("--block-minutes", type=float, default=2.0)
    ap.add_argument("--rate-hz", type=float, default=5.0)
    ap.add_argument("--interval-ms", type=int, default=170, help="PLC pause between cycles (the handshake takes ~30 ms: ~5 Hz)")
    ap.add_argument("--quota-mb", type=float, default=20)
    ap.add_argument("--every-nth-good", type=int, default=100)
    ap.add_argument("--empty-every", type=int, default=10)
    ap.add_argument("--out", default="")
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args()

    work = tempfile.mkdtemp(prefix="vgr-archive-bench-")
    archive = os.path.join(work, "archive")
    journals = {"archive": os.path.join(work, "journal-archive.jsonl"), "none": os.path.join(work, "journal-none.jsonl")}
    res = {"archive": [], "none": []}
    load = [os.getloadavg()]
    for b in range(args.blocks):
        for mode in (("archive", "none") if b % 2 == 0 else ("none", "archive")):
            r = run_block(args, work, mode, args.block_minutes * 60, journals[mode], archive, b)
            res[mode].append(r)
            print(f"block {b + 1} {mode}: {r['answered']}/{r['cycles']} cycles in {r['elapsed_s']:.0f} s, "
                  f"p99 {pct(r['plc_latency_ms'], 99):.1f} ms, cpu {r['cpu_s']:.1f} s, peak {r['peak_bytes'] / 1e6:.2f} MB",
                  flush=True)
            load.append(os.getloadavg())

    summary = {}
    for mode in ("none", "archive"):
        lat = [x for r in res[mode] for x in r["plc_latency_ms"]]
        lines = journal_lines(journals[mode])
        total = [l["total_ms"] for l in lines]
        total_ok = [l["total_ms"] for l in lines if l["status"] == 0]
        cycles = sum(r["answered"] for r in res[mode])
        secs = sum(r["elapsed_s"] for r in res[mode])
        summary[mode] = {
            "cycles": cycles, "rate_hz": cycles / secs if secs else 0, "minutes": secs / 60,
            "failed": sum(1 for l in lines if l["status"] != 0),
            "plc_latency_p50_ms": pct(lat, 50), "plc_latency_p99_ms": pct(lat, 99),
            "total_ms_p50": pct(total, 50), "total_ms_p99": pct(total, 99),
            "total_ms_ok_p50": pct(total_ok, 50), "total_ms_ok_p99": pct(total_ok, 99),
            "cpu_ms_per_cycle": 1000 * sum(r["cpu_s"] for r in res[mode]) / max(1, cycles),
        }
    # The archive's rules over the whole archive run.
    lines = journal_lines(journals["archive"])
    named = [l["archive"] for l in lines if "archive" in l]
    present = [os.path.exists(os.path.join(archive, n)) for n in named]
    first = present.index(True) if True in present else len(named)
    failed_frames = [l for l in lines if l["status"] != 0 and l.get("frame_id", 0) > 0]
    failed_unreferenced = [l["cycle"] for l in failed_frames if "archive" not in l]
    gaps = [named[i] for i in range(first, len(named)) if not present[i]]
    quota = int(args.quota_mb * 1e6)
    summary["archive"].update({
        "quota_bytes": quota, "peak_bytes": max(r["peak_bytes"] for r in res["archive"]), "final_bytes": folder_bytes(archive),
        "named_by_journal": len(named), "left": len(named) - first, "gaps_in_newest": len(gaps),
        "failed_cycles_without_archive": len(failed_unreferenced),
        "failed_in_archive_now": sum(1 for l in failed_frames if "archive" in l and os.path.exists(os.path.join(archive, l["archive"]))),
    })
    s, a = summary["none"], summary["archive"]
    summary["p99_ratio_plc"] = a["plc_latency_p99_ms"] / s["plc_latency_p99_ms"]
    summary["p99_ratio_total_ms"] = a["total_ms_p99"] / s["total_ms_p99"]
    summary["load_avg"] = load
    summary["quota_ok"] = a["peak_bytes"] <= quota
    summary["references_ok"] = not gaps and not failed_unreferenced
    print(json.dumps(summary, indent=1))
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"summary": summary, "blocks": res}, f)
    if not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    else:
        print("kept", work)
    return 0 if summary["quota_ok"] and summary["references_ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
