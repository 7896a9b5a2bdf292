#!/usr/bin/env python3
"""Whole-process benchmarks and the page of every figure (run by scripts/bench.sh).

Reads the criterion results of `cargo bench --bench codecs --bench session`
(only estimates written since --criterion-since), serves the simulated bench at
wire speed (`axisctl sim --wire-speed`) on pseudo-terminals, measures scans,
one-shot commands, polling throughput and the dashboard, asks
scripts/bench_record.py and scripts/bench_batch.py for their figures, and
prints one table: figure, measured, reference / goal, verdict. A verdict is
given only where a goal exists. With --markdown FILE the whole page
(docs/performance.md.in with every placeholder filled from this run) is written
there. Any missing or stale figure fails the run and no page is written.
"""

import argparse
import importlib
import json
import os
import platform
import re
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path

from benchlib import AXISCTL, ROOT, TARGET, Sim

TEMPLATE = ROOT / "docs" / "performance.md.in"

# References that are not ours to measure, with where they come from.
VENDOR_SCAN_S = 26.1  # SCHUNK's libm5api scan of the served bench, measured by issue 15's reporter
VENDOR_READ_TIMEOUT_S = 0.030  # libm5api's Linux read timeout, per module counted
SCAN_IDS = 31  # `scan` probes ids 1..31
CAN_TIMEOUT_S = 0.100  # the PowerCube session's CAN answer timeout (src/session/powercube.rs CAN_TIMEOUT)

# Wire bits of the frames involved (ISO 11898-1 without stuff bits: 47 + 8 per data byte)
# and serial characters at 10 bits (8N1): what the codec figures are compared with.
CAN_BIT_S = 1e-6  # 1 Mbit/s


def can_frame_s(data_bytes):
    return (47 + 8 * data_bytes) * CAN_BIT_S


def serial_s(chars, baud=9600, bits=10):
    return chars * bits / baud


rows = []  # (figure, measured, reference, verdict, command, limit)
facts = {}  # the prose's placeholders, each from this run
loads = []  # 1-min load average after each group of figures


class Missing(Exception):
    """A figure could not be measured, or only a stale one was found."""


def add(figure, measured, reference, ok, command, limit):
    """One row. `ok`: True / False against the row's goal; None where no goal decides."""
    if measured is None or str(measured).strip() == "":
        raise Missing(f"{figure}: no measurement")
    verdict = {True: "pass", False: "FAIL", None: "no goal"}[ok]
    rows.append((figure, measured, reference, verdict, command, limit))


def sample_load():
    loads.append(os.getloadavg()[0])


def fmt_s(s):
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.1f} ms"
    if s >= 1e-6:
        return f"{s * 1e6:.2f} µs"
    return f"{s * 1e9:.0f} ns"


def run_times(argv, n, env=None):
    """Wall time of `argv` as a whole process, n runs: (min, median, p90, last result)."""
    times = []
    result = None
    for _ in range(n):
        t0 = time.perf_counter()
        result = subprocess.run(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
        times.append(time.perf_counter() - t0)
        if result.returncode != 0:
            sys.exit(f"{' '.join(map(str, argv))} failed ({result.returncode}): {result.stderr}")
    times.sort()
    return times[0], statistics.median(times), times[min(n - 1, int(0.9 * n))], result


CRITERION_SINCE = None  # set from --criterion-since: estimates older than this are stale


def criterion(name):
    """Median of a criterion benchmark of this run, in seconds."""
    est = TARGET / "criterion" / name.replace("/", "_") / "new" / "estimates.json"
    if not est.exists():
        raise Missing(f"criterion estimate {est} is missing")
    if CRITERION_SINCE is None or est.stat().st_mtime < CRITERION_SINCE:
        raise Missing(f"criterion estimate {est} is older than this run (pass --criterion-since, as bench.sh does)")
    return json.loads(est.read_text())["median"]["point_estimate"] * 1e-9


def codec_figures():
    can_req, can_ans = can_frame_s(2), can_frame_s(6)
    ref = {
        # bench name: (what, wire time of that frame at the fastest link)
        "powercube/can_encode": ("PowerCube CAN request encode", can_req, "2-byte frame at 1 Mbit/s"),
        "powercube/can_decode": ("PowerCube CAN answer decode", can_ans, "6-byte frame at 1 Mbit/s"),
        "powercube/rs232_encode": ("PowerCube RS232 request encode", serial_s(7), "7 chars at 9600 baud"),
        "powercube/rs232_decode": ("PowerCube RS232 answer decode (stream)", serial_s(12), "12 chars at 9600 baud"),
        "pac/command_encode": ("PA-CONTROL command encode", serial_s(16, bits=9), "16 chars 7N1 at 9600 baud"),
        "pac/ack_decode": ("PA-CONTROL ack decode (stream)", serial_s(20, bits=9), "20 chars 7N1 at 9600 baud"),
        "cdios/command_encode": ("Cdios command encode", can_frame_s(8), "8-byte frame at 1 Mbit/s"),
        "cdios/answer_decode": ("Cdios answer classify + decode", can_frame_s(8), "8-byte frame at 1 Mbit/s"),
        "slcan/frame_encode": ("slcan line encode", can_frame_s(2), "2-byte frame at 1 Mbit/s"),
        "slcan/frame_decode": ("slcan line decode", can_frame_s(6), "6-byte frame at 1 Mbit/s"),
    }
    codec = {}
    for name, (what, wire, wire_what) in ref.items():
        t = criterion(name)
        codec[what] = t
        add(
            f"{what}, per frame",
            fmt_s(t),
            f"< 1 % of the frame's wire time ({fmt_s(wire)}, {wire_what})",
            t < 0.01 * wire,
            f"cargo bench --bench codecs -- {name}",
            "CPU only; no I/O",
        )
    slowest = max(codec, key=codec.get)
    facts.update(
        codec_min=fmt_s(min(codec.values())),
        codec_max=fmt_s(max(codec.values())),
        codec_slowest=slowest,
        shortest_frame=fmt_s(can_req),
    )
    session = []
    for name, what in [
        ("session/powercube_can_get", "PowerCube get over CAN"),
        ("session/powercube_rs232_get", "PowerCube get over RS232"),
        ("session/pac_get", "PA-CONTROL get-actual-pos"),
        ("session/cdios_read_position", "Cdios read position"),
    ]:
        t = criterion(name)
        session.append(t)
        add(
            f"Session + codec per transaction, in-process link: {what}",
            fmt_s(t),
            "goal < 5 µs",
            t < 5e-6,
            f"cargo bench --bench session -- {name}",
            "encode, link calls, match, decode, clock reads; the responder answers at once",
        )
    facts.update(session_min=fmt_s(min(session)), session_max=fmt_s(max(session)))


def rs232_scan_limit(log, window):
    """Wire time of the logged scan traffic at 9600 8N1, plus the answer-start window for each
    unanswered request."""
    tx_frames, rx_bytes, tx_bytes, etx = 0, [], 0, 0
    for line in log.read_text().splitlines():
        _, direction, *hexes = line.split()
        data = [int(h, 16) for h in hexes]
        if direction == "tx":
            tx_frames += 1
            tx_bytes += len(data)
        else:
            rx_bytes += data
    prev = None
    for b in rx_bytes:
        if b == 0x03 and prev != 0x10:
            etx += 1
        prev = b
    unanswered = tx_frames - etx
    wire = serial_s(tx_bytes + len(rx_bytes))
    return wire + unanswered * window, tx_frames, unanswered, wire


def answer_window(trace):
    """The answer-start window and answer timeout the binary says it scans with (`--trace`)."""
    m = re.search(r"answer-start window ([0-9.]+) ms \(answer timeout ([0-9.]+) ms\)", trace)
    if not m:
        raise Missing("the scan's --trace does not state its answer-start window")
    return float(m.group(1)) * 1e-3, float(m.group(2)) * 1e-3


def scan_figures(serial_link, slcan_link, n):
    log = Path("/tmp/axisctl-bench-scan.log")
    log.unlink(missing_ok=True)
    traced = subprocess.run(
        [AXISCTL, "--link", serial_link, "--log", log, "--trace", "scan"],
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    window, timeout = answer_window(traced.stderr)
    limit, frames, unanswered, wire = rs232_scan_limit(log, window)
    lo, med, p90, _ = run_times([AXISCTL, "--link", serial_link, "scan"], n)
    add(
        "Scan of ids 1..31, 3 modules, RS232 9600 baud (whole process)",
        f"{fmt_s(med)} median (min {fmt_s(lo)}, p90 {fmt_s(p90)}, {n} runs)",
        "goal < 1 s; vendor C library 26.1 s (measured by issue 15's reporter)",
        med < 1.0,
        f"axisctl --link '{serial_link}' scan  # against axisctl sim --wire-speed --powercube pty-serial",
        f"{frames} requests, {unanswered} unanswered: {fmt_s(wire)} of wire time + {unanswered} x {fmt_s(window)} "
        f"answer-start window (from the binary's --trace) = {fmt_s(limit)}",
    )
    log.unlink(missing_ok=True)
    vendor_per_absent = VENDOR_READ_TIMEOUT_S * SCAN_IDS
    facts.update(
        rs232_present=fmt_s(serial_s(7 + 12)),
        rs232_request=fmt_s(serial_s(7)),
        window=fmt_s(window),
        answer_timeout=fmt_s(timeout),
        rs232_limit=fmt_s(limit),
        rs232_requests=str(frames),
        rs232_unanswered=str(unanswered),
        rs232_scan=f"{fmt_s(med)} (median)",
        vendor_scan=fmt_s(VENDOR_SCAN_S),
        vendor_ratio=f"{VENDOR_SCAN_S / med:.0f}",
        vendor_read_timeout=fmt_s(VENDOR_READ_TIMEOUT_S),
        scan_ids=str(SCAN_IDS),
        vendor_per_absent=f"{SCAN_IDS} x {fmt_s(VENDOR_READ_TIMEOUT_S)} = {fmt_s(vendor_per_absent)}",
        vendor_absent_total=fmt_s(unanswered * vendor_per_absent),
    )
    sample_load()
    lo, med, p90, _ = run_times([AXISCTL, "--link", slcan_link, "scan"], n)
    add(
        "Scan of ids 1..31, 3 modules, CAN 1 Mbit/s via slcan (whole process)",
        f"{fmt_s(med)} median (min {fmt_s(lo)}, p90 {fmt_s(p90)}, {n} runs)",
        "goal < 0.2 s",
        med < 0.2,
        f"axisctl --link {slcan_link} scan  # against axisctl sim --wire-speed",
        f"one {fmt_s(CAN_TIMEOUT_S)} answer timeout for the {unanswered} absent ids (all {SCAN_IDS} requests "
        "pipelined), then the frames and the process",
    )
    facts.update(can_timeout=fmt_s(CAN_TIMEOUT_S), can_scan=fmt_s(med), can_scan_rest=fmt_s(med - CAN_TIMEOUT_S))
    sample_load()


def get_param_figures(slcan_link, n):
    tty = slcan_link.split(":", 1)[1].split("?")[0]
    lo, med, p90, _ = run_times(["/bin/true"], n)
    spawn = med
    lo, med, p90, _ = run_times([AXISCTL, "--link", slcan_link, "get-param", "-m", "3", "ActPos"], n)
    plo, pmed, pp90, res = run_times([sys.executable, ROOT / "scripts" / "bench_python_can.py", tty], n)
    exchange = re.search(r"exchange ([0-9.]+) ms", res.stderr)
    if not exchange:
        raise Missing(f"bench_python_can.py did not report its exchange time: {res.stderr!r}")
    add(
        "One-shot get-param over an slcan pty, whole process (open, ActPos + Config pipelined, print)",
        f"{fmt_s(med)} median (min {fmt_s(lo)}, p90 {fmt_s(p90)}, {n} runs)",
        f"goal < 20 ms; python-can doing the same: {fmt_s(pmed)} median (min {fmt_s(plo)}, p90 {fmt_s(pp90)}; "
        f"last run inside the script: {res.stderr.strip()})",
        med < 0.02,
        f"axisctl --link {slcan_link} get-param -m 3 ActPos  vs  python3 scripts/bench_python_can.py {tty}",
        f"process start ({fmt_s(spawn)} for /bin/true from this harness), adapter setup C/S8/O with replies, "
        f"2 x (2-byte request + 6-byte answer) at 1 Mbit/s = {fmt_s(2 * (can_frame_s(2) + can_frame_s(6)))}",
    )
    facts.update(
        get_param=f"{fmt_s(med)} (median)",
        python_can=f"{fmt_s(pmed)} (median)",
        python_exchange=fmt_s(float(exchange.group(1)) * 1e-3),
    )
    sample_load()


def cdios_status_figure(slcan_link, n):
    """One-shot cdios-status on a node that runs: started once, then measured."""
    argv = [AXISCTL, "--link", slcan_link, "cdios-status", "-m", "0"]
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL)  # the node runs from here on
    log = Path("/tmp/axisctl-bench-cdios.log")
    log.unlink(missing_ok=True)
    subprocess.run([*argv[:3], "--log", log, *argv[3:]], check=True, stdout=subprocess.DEVNULL)
    sent = [l.split()[-1] for l in log.read_text().splitlines() if l.split()[-1].startswith(("000#", "201#"))]
    log.unlink(missing_ok=True)
    if any(f.startswith("000#") for f in sent):
        raise Missing(f"cdios-status sent an NMT start to a running node: {sent}")
    lo, med, p90, _ = run_times(argv, n)
    add(
        "One-shot cdios-status on a running node over an slcan pty, whole process (status and speed reads, print)",
        f"{fmt_s(med)} median (min {fmt_s(lo)}, p90 {fmt_s(p90)}, {n} runs)",
        "goal < 20 ms",
        med < 0.02,
        f"axisctl --link {slcan_link} cdios-status -m 0  # against axisctl sim --wire-speed, node started once",
        f"process start, adapter setup, {len(sent)} x (8-byte command + 8-byte answer) at 1 Mbit/s = "
        f"{fmt_s(len(sent) * 2 * can_frame_s(8))}; no NMT start and no settle time (checked in the run's --log)",
    )
    facts.update(cdios_status=f"{fmt_s(med)} (median)", cdios_frames=str(len(sent)))
    sample_load()


def with_format(link, fmt):
    """`link` with an explicit serial format, unless it has one."""
    if "format=" in link:
        return link
    return f"{link}{'&' if '?' in link else '?'}format={fmt}"


def cargo_bench_poll(*args, env=None):
    out = subprocess.run(
        ["cargo", "bench", "--quiet", "--bench", "poll", "--", *map(str, args)],
        cwd=ROOT,
        check=True,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def poll_figures(cases, seconds, repeats):
    """The dashboard's worker polling round after round, metered against the wire.
    `cases`: (fact name or None, what, link, families, limit)."""
    for fact, what, link, families, limit in cases:
        runs = sorted(
            (cargo_bench_poll(link, seconds, *families) for _ in range(repeats)), key=lambda d: d["wire_busy_fraction"]
        )
        d = runs[len(runs) // 2]
        frac = d["wire_busy_fraction"]
        add(
            f"Dashboard worker polling throughput, {what}",
            f"{100 * frac:.1f} % of the wire limit ({d['rounds_per_second']:.1f} rounds/s over {d['devices']} devices); "
            f"median of {repeats} x {seconds:g} s ("
            + ", ".join(f"{100 * r['wire_busy_fraction']:.1f} %" for r in runs)
            + ")",
            "goal >= 90 % of the wire limit",
            frac >= 0.9,
            f"cargo bench --bench poll -- '{link}' {seconds:g} {' '.join(families)}".rstrip(),
            limit,
        )
        if fact:
            facts[fact] = f"{100 * frac:.1f} %"
        sample_load()


def pty_rtt_figure():
    d = cargo_bench_poll("pty-rtt", 5000)
    add(
        "pty round trip of one slcan line (host → pty → echo thread → pty → host)",
        f"{d['median_us']:.1f} µs median (p90 {d['p90_us']:.1f} µs, {d['round_trips']} round trips)",
        "no goal: what each CAN exchange pays over a pty on top of its wire time (a USB adapter: 125 µs..1 ms)",
        None,
        "cargo bench --bench poll -- pty-rtt 5000",
        "two kernel tty flushes (workqueue) and two wake-ups",
    )
    facts["pty_rtt"] = f"{d['median_us']:.1f} µs"


def dashboard_figures(links, seconds):
    if subprocess.run([AXISCTL, "dashboard", "--help"], capture_output=True).returncode != 0:
        raise Missing("axisctl dashboard is not in this build")
    session = f"axisctl-bench-{os.getpid()}"  # two runs at once must not end each other's
    # PowerCube and Cdios share the slcan bus (one link, one worker), the PA-CONTROL its own line.
    cmd = [str(AXISCTL), "--link", links["powercube"], "dashboard", "--rate", "20", "--pac-link", links["pac"]]
    subprocess.run(["tmux", "kill-session", "-t", session], capture_output=True)
    subprocess.run(["tmux", "new-session", "-d", "-s", session, "-x", "120", "-y", "40", shlex.join(cmd)], check=True)
    try:
        time.sleep(3)  # discovery and the first rounds
        pid = int(
            subprocess.run(
                ["pgrep", "-n", "-f", f"{AXISCTL} --link {links['powercube']} dashboard"], check=True, capture_output=True, text=True
            ).stdout.split()[0]
        )
        tick = os.sysconf("SC_CLK_TCK")

        def cpu(stat):
            f = Path(stat).read_text().rsplit(")", 1)[1].split()
            return (int(f[11]) + int(f[12])) / tick

        def threads():
            """CPU seconds by thread name (the UI thread is named after the binary)."""
            out = {}
            for task in Path(f"/proc/{pid}/task").iterdir():
                try:
                    name = (task / "comm").read_text().strip()
                    out[name] = out.get(name, 0.0) + cpu(task / "stat")
                except OSError:
                    pass  # a thread that ended between the listing and the read
            return out

        c0, th0, t0 = cpu(f"/proc/{pid}/stat"), threads(), time.perf_counter()
        time.sleep(seconds)
        c1, th1, t1 = cpu(f"/proc/{pid}/stat"), threads(), time.perf_counter()
        status = Path(f"/proc/{pid}/status").read_text()
        rss = {k: int(v.split()[0]) for k, v in (l.split(":", 1) for l in status.splitlines()) if k in ("VmRSS", "VmHWM")}
    finally:
        subprocess.run(["tmux", "kill-session", "-t", session], capture_output=True)
    share = (c1 - c0) / (t1 - t0)
    by_thread = sorted(((th1.get(n, 0.0) - th0.get(n, 0.0)) / (t1 - t0), n) for n in th1)
    split = ", ".join(f"{n} {100 * v:.2f} %" for v, n in reversed(by_thread) if v > 0)
    add(
        "Dashboard CPU at 20 Hz, full simulated bench (3 PowerCube + 2 Cdios on slcan, PA-CONTROL on 9600 7N1)",
        f"{100 * share:.2f} % of a core over {seconds} s",
        "goal < 2 % of a core",
        share < 0.02,
        f"tmux: {shlex.join(cmd)}; /proc/PID/stat and /proc/PID/task/*/stat utime+stime",
        f"by thread ({split or 'none measurable'}): polling (each CAN answer is read as it arrives at wire "
        "speed; a PA-CONTROL acknowledge in a few pieces) and drawing, at most 10 frames/s for worker reports; "
        "the served links run in another process",
    )
    add(
        "Dashboard memory at 20 Hz, full simulated bench",
        f"RSS {rss['VmRSS'] / 1024:.1f} MB (peak {rss['VmHWM'] / 1024:.1f} MB)",
        "goal RSS < 20 MB",
        rss["VmHWM"] < 20 * 1024,
        "/proc/PID/status VmRSS, VmHWM",
        "binary text, ratatui buffers, per-link workers",
    )
    facts.update(dashboard_cpu=f"{100 * share:.2f} % of a core", dashboard_rss=f"{rss['VmRSS'] / 1024:.1f} MB")
    sample_load()


def helper_figures(links):
    """The figures of scripts/bench_record.py and scripts/bench_batch.py: each module's
    figures(add, links) adds its rows; a module that is missing, or adds none, fails the run."""
    sys.path.insert(0, str(ROOT / "scripts"))
    for name in ("bench_record", "bench_batch"):
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as e:
            raise Missing(f"scripts/{name}.py is missing: {e}") from e
        before = len(rows)
        module.figures(add, dict(links))
        if len(rows) == before:
            raise Missing(f"scripts/{name}.py added no figure")
        sample_load()


def table():
    lines = [
        "| Figure | Measured | Reference / goal | Verdict | Command | What limits it |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        cells = [str(c).replace("|", "\\|") for c in r]
        cells[4] = f"`{cells[4]}`"
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def cpu_model():
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def page(started):
    """docs/performance.md.in with every placeholder filled; a placeholder this run has no
    value for, or a value no placeholder takes, is a missing figure."""
    load = os.getloadavg()
    values = dict(
        facts,
        table=table(),
        cpus=str(os.cpu_count()),
        cpu_model=cpu_model(),
        kernel=platform.release(),
        started=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(started)),
        load_min=f"{min(loads):.2f}",
        load_max=f"{max(loads):.2f}",
        load_end=f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f}",
    )
    text = TEMPLATE.read_text()
    wanted = set(re.findall(r"\{\{(\w+)\}\}", text))
    if wanted - values.keys():
        raise Missing(f"no value from this run for {sorted(wanted - values.keys())} in {TEMPLATE}")
    unused = values.keys() - wanted
    if unused:
        raise Missing(f"{TEMPLATE} does not show {sorted(unused)}")
    return re.sub(r"\{\{(\w+)\}\}", lambda m: values[m.group(1)], text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--markdown", help="write the whole page (docs/performance.md.in filled) here")
    ap.add_argument(
        "--criterion-since",
        type=float,
        help="epoch seconds: criterion estimates older than this are stale (bench.sh passes its start)",
    )
    ap.add_argument("--runs", type=int, default=20, help="runs of each whole-process command")
    ap.add_argument("--poll-seconds", type=float, default=3.0)
    ap.add_argument("--poll-repeats", type=int, default=3)
    ap.add_argument(
        "--only-dashboard",
        action="store_true",
        help="measure the dashboard's CPU and memory alone, print them, write no page (for tuning)",
    )
    ap.add_argument("--dashboard-seconds", type=float, default=10.0)
    args = ap.parse_args()
    global CRITERION_SINCE
    CRITERION_SINCE = args.criterion_since
    started = time.time()
    if args.only_dashboard and args.markdown:
        sys.exit("bench: --only-dashboard writes no page: a page is written whole by one full run")
    try:
        run_all(args)
        text = page(started) if args.markdown else None
    except Missing as e:
        sys.exit(f"bench: {e}; no page written")
    width = [max(len(str(r[i])) for r in rows) for i in range(4)]
    head = ("Figure", "Measured", "Reference / goal", "Verdict")
    width = [min(max(w, len(h)), 70) for w, h in zip(width, head)]
    print("  ".join(h.ljust(w) for h, w in zip(head, width)))
    for r in rows:
        print("  ".join(str(c).ljust(w) for c, w in zip(r[:4], width)))
    if args.only_dashboard:
        for r in rows:
            print(f"{r[0]}: {r[5]}")
    load = os.getloadavg()
    print(f"\nload average at the end of the run: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
    if text is not None:
        Path(args.markdown).write_text(text)
        print(f"page written to {args.markdown}")
    return 0 if all(r[3] != "FAIL" for r in rows) else 1


def run_all(args):
    if args.only_dashboard:
        full = Sim("--wire-speed")
        try:
            dashboard_figures(full.links, args.dashboard_seconds)
        finally:
            full.stop()
        return
    sample_load()
    codec_figures()
    sample_load()
    full = Sim("--wire-speed")
    serial = Sim("--wire-speed", "--powercube", "pty-serial")
    remote = Sim("--wire-speed", "--socketcand", "127.0.0.1:0")
    try:
        slcan = full.links["powercube"]
        scan_figures(serial.links["powercube"], slcan, max(5, args.runs // 4))
        get_param_figures(slcan, args.runs)
        cdios_status_figure(full.links["cdios"], args.runs)
        helper_figures(full.links)
        can = slcan + "?bitrate=1000000"
        in_proc = "in-process bench at wire speed (no pty)"
        poll_figures(
            [
                (
                    "can_poll_pc",
                    "PowerCube modules 3, 5, 17 on CAN 1 Mbit/s via an slcan pty",
                    can,
                    ["powercube"],
                    "per module: 7 reads pipelined = 7 x (2-byte request + 6-byte answer) ≈ 1.2 ms of frames; "
                    "the next module's burst goes out before this one's answers are read, so a round pays one "
                    "turnaround (see the pty round trip) at its start instead of one per module",
                ),
                (
                    "can_poll_cdios",
                    "Cdios node 1 modules 0, 1 on CAN 1 Mbit/s via an slcan pty",
                    can,
                    ["cdios"],
                    "per module: 4 reads pipelined = 8 x 8-byte frames ≈ 0.9 ms of wire time; the next "
                    "module's burst goes out before this one's replies are read, so a round pays one turnaround",
                ),
                (
                    "can_poll_full",
                    "full CAN link (PowerCube + Cdios) at 1 Mbit/s via an slcan pty",
                    can,
                    [],
                    "as the two rows above, interleaved; each device's burst goes out while the device before "
                    "it is read, whatever its family",
                ),
                (
                    "rs232_poll_pc",
                    "PowerCube over RS232 9600 baud 8N1 (pty)",
                    serial.links["powercube"],
                    [],
                    "half duplex: 7-byte request + 12-byte answer = 19.8 ms of wire time per read",
                ),
                (
                    "rs232_poll_pac",
                    "PA-CONTROL over RS232 9600 baud 7N1 (pty)",
                    # The harness reads a link without a format as 8N1 (PowerCube); sim leaves the
                    # PA-CONTROL's default 7N1 out of the link it announces.
                    with_format(full.links["pac"], "7N1"),
                    [],
                    "half duplex: ~17-char command + ~19-char acknowledge at 9 bits ≈ 34 ms per read",
                ),
                (
                    "socketcand_poll",
                    "full CAN link (PowerCube + Cdios) at 1 Mbit/s through socketcand on localhost (TCP)",
                    remote.links["powercube"],
                    [],
                    "as the slcan row, with each burst and its answers crossing a TCP connection and the "
                    "daemon's loop (axisctl sim --socketcand, one read per burst, one write for the frames due) "
                    "instead of the pty",
                ),
                (None, f"PowerCube, {in_proc}, 1 Mbit/s", "sim", ["powercube"], "timer wake-up per answer frame"),
                (None, f"Cdios, {in_proc}, 1 Mbit/s", "sim", ["cdios"], "timer wake-up per answer frame"),
                (None, f"full CAN bench, {in_proc}, 1 Mbit/s", "sim", [], "timer wake-up per answer frame"),
            ],
            args.poll_seconds,
            args.poll_repeats,
        )
        pty_rtt_figure()
        dashboard_figures(full.links, args.dashboard_seconds)
    finally:
        full.stop()
        serial.stop()
        remote.stop()


if __name__ == "__main__":
    sys.exit(main())
