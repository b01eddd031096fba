#!/usr/bin/python3
"""Checks circlog-record traces for the HAL tests; prints stable lines compared with `expected`.

Parsed independently of circtest's reader, so a bug there cannot hide one in the recorder.
"""
import sys


def read_trace(path):
    meta, columns, rows = {}, None, []
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if line.startswith("#"):
                key, _, value = line[1:].strip().partition(":")
                meta[key.strip()] = value.strip()  # the last value of a key wins
            elif columns is None:
                columns = line.split(",")
            elif line:
                rows.append([float(v) for v in line.split(",")])
    return meta, columns, rows


def col(columns, rows, name):
    i = columns.index(name)
    return [r[i] for r in rows]


def yes(ok):
    return "yes" if ok else "NO"


def runs_of(marker, segment):
    """Runs as the analysis splits them: marker non-zero, split where segment changes."""
    runs, i = [], 0
    while i < len(marker):
        if marker[i] < 0.5:
            i += 1
            continue
        j = i + 1
        while j < len(marker) and marker[j] >= 0.5 and segment[j] == segment[i]:
            j += 1
        runs.append((i, j))
        i = j
    return runs


def consecutive(periods):
    return all(b == a + 1 for a, b in zip(periods, periods[1:]))


def common(meta, columns, rows):
    period = float(meta["sample_period_s"])
    t = col(columns, rows, "t")
    p = col(columns, rows, "period")
    print("rows metadata matches:", yes(int(meta["rows"]) == len(rows)))
    print("t = period x sample_period_s:",
          yes(all(abs(a - b * period) < 1e-9 for a, b in zip(t, p))))
    for key in ("sample_period_s", "module.channels", "module.depth", "channels"):
        print(f"{key}: {meta.get(key)}")
    print("start_time is ISO 8601 UTC:", yes(meta.get("start_time", "").endswith("Z")))


def signals(trace, sampler, *times):
    meta, columns, rows = read_trace(trace)
    common(meta, columns, rows)
    for key in ("overruns", "gaps", "lost_samples", "runs", "stop_reason"):
        print(f"{key}: {meta.get(key)}")
    marker = col(columns, rows, "marker")
    on = [r for r, m in zip(rows, marker) if m == 1]
    ref = []
    with open(sampler) as f:
        for line in f:
            if line.strip():
                ref.append([float(v) for v in line.split()])
    print("rows with marker 1 equal the enabled periods (sampler's count):",
          yes(len(on) == len(ref)))
    # The enable was on from between times t0 and t1 (before and after the halcmd call that
    # set it) to between t2 and t3 (the one that cleared it): one row per 1 ms period of that
    # wall time, a period missed now and then where the thread is late.
    t0, t1, t2, t3 = (float(t) for t in times)
    lo, hi = 0.8 * (t2 - t1) * 1000, (t3 - t0) * 1000 + 5
    print("one row per 1 ms period of the enabled time:", yes(lo <= len(on) <= hi))
    print("rows with marker 0:", sum(1 for m in marker if m == 0), "(the period enable fell)")
    print("last row has marker 0:", yes(marker[-1] == 0))
    print("period counters consecutive:", yes(consecutive(col(columns, rows, "period"))))
    names = meta["channels"].split(",")
    idx = [columns.index(n) for n in names]
    worst = 0.0
    for r, s in zip(on, ref):
        for k, i in enumerate(idx):
            worst = max(worst, abs(r[i] - s[k]))
    print("values equal the sampler's (to the 6 printed decimals):", yes(worst <= 1.5e-6))
    print("constant channel in-07:", sorted(set(col(columns, rows, "in-07"))))
    print("segment values:", sorted(set(col(columns, rows, "segment"))))
    amp = max(col(columns, rows, "in-00")) - 3.0
    print("sine amplitude about 25:", yes(abs(amp - 25.0) < 0.01))


def overruns(trace, pin_overruns, recorder_rc, enabled_periods):
    meta, columns, rows = read_trace(trace)
    common(meta, columns, rows)
    lost = int(meta["lost_samples"])
    print("overruns > 0:", yes(int(meta["overruns"]) > 0))
    print("overruns metadata equals the circlog.0.overruns pin:",
          yes(int(meta["overruns"]) == int(pin_overruns)))
    print("lost_samples equals overruns:", yes(lost == int(meta["overruns"])))
    print("gaps > 0:", yes(int(meta["gaps"]) > 0))
    print("recorder exit code:", recorder_rc)
    marker = col(columns, rows, "marker")
    periods = [int(p) for p in col(columns, rows, "period")]
    on = [p for p, m in zip(periods, marker) if m == 1]
    jumps = sum(b - a - 1 for a, b in zip(periods, periods[1:]) if b != a + 1)
    print("period counter shows the gaps:", yes(jumps > 0))
    # Every enabled period plus the one where enable fell was attempted: the rows and the
    # lost records account for all of them.
    print("rows + lost_samples = enabled periods + 1:",
          yes(len(rows) + lost == int(enabled_periods) + 1))
    # The first record of the run always fits (the ring starts empty), so the run's last
    # attempted period is known: what is missing after the last row was lost at the end.
    after_last = periods[0] + int(enabled_periods) - periods[-1]
    print("lost records = period gaps + records missing after the last row:",
          yes(lost == jumps + after_last))
    print("rows with marker 1 at most the enabled periods:", yes(len(on) <= int(enabled_periods)))


def runs(trace):
    meta, columns, rows = read_trace(trace)
    common(meta, columns, rows)
    for key in ("runs", "lost_samples", "plane", "radius_mm", "feed_mm_per_min"):
        print(f"{key}: {meta.get(key)}")
    print("program:", "PROGRAM" if meta.get("program", "").endswith("/program.ngc") else None)
    print("channel.x:", meta.get("channel.x"))
    print("columns:", ",".join(columns))
    marker = col(columns, rows, "marker")
    segment = col(columns, rows, "segment")
    period = [int(p) for p in col(columns, rows, "period")]
    found = runs_of(marker, segment)
    print("runs split on marker and segment:", len(found))
    for n, (b, e) in enumerate(found, 1):
        print(f"  run {n}: segment {int(segment[b])}, consecutive periods:",
              yes(consecutive(period[b:e])), ", at least 200 rows:", yes(e - b >= 200))
    print("marker-0 rows between runs:", sum(1 for m in marker if m == 0))


def read_ctb(path):
    """The binary form (docs/trace-format.md): metadata, columns, row count and a reader of the
    rows in chunks (memoryviews of float64), without holding the whole file."""
    import struct
    f = open(path, "rb")
    if f.read(8) != b"CTRACEB1":
        raise SystemExit(f"{path}: not a .ctb")
    (h,) = struct.unpack("<I", f.read(4))
    header = f.read(h).decode().splitlines()
    size = f.seek(0, 2)
    f.seek(size - 16)
    n, t = struct.unpack("<QI", f.read(12))
    if f.read(4) != b"CTBE":
        raise SystemExit(f"{path}: no end magic")
    f.seek(size - 16 - t)
    trailer = f.read(t).decode().splitlines()
    meta = {}
    for line in header[:-1] + trailer:
        key, _, value = line[1:].strip().partition(":")
        meta[key.strip()] = value.strip()
    columns = header[-1].split(",")
    rows_bytes = size - 16 - t - 12 - h

    def chunks(rows_per_chunk=65536):
        f.seek(12 + h)
        left = n
        while left:
            k = min(left, rows_per_chunk)
            yield memoryview(f.read(8 * len(columns) * k)).cast("d")
            left -= k

    return meta, columns, n, rows_bytes, chunks


def soak(trace, pin_overruns, recorder_rc, duration_s):
    meta, columns, n, rows_bytes, chunks = read_ctb(trace)
    c = len(columns)
    period_s = float(meta["sample_period_s"])
    failures = []

    def expect(ok, what):
        if not ok:
            failures.append(what)

    expect(rows_bytes == 8 * c * n, "row block size differs from the row count")
    expect(int(meta["rows"]) == n, "rows metadata differs from the rows in the file")
    ip, it, im = columns.index("period"), columns.index("t"), columns.index("marker")
    first = last = None
    jumps = marker_off = 0
    worst_t = 0.0
    for mv in chunks():
        periods = mv[ip::c].tolist()
        times = mv[it::c].tolist()
        marker_off += mv[im::c].tolist().count(0.0)
        if last is not None and periods[0] != last + 1:
            jumps += 1
        if first is None:
            first = periods[0]
        jumps += sum(1 for a, b in zip(periods, periods[1:]) if b != a + 1)
        worst_t = max(worst_t, max(abs(tt - pp * period_s) for tt, pp in zip(times, periods)))
        last = periods[-1]
    expected = float(duration_s) / period_s
    print(f"rows: {n} ({n * period_s:.1f} s of servo time at {1 / period_s:.0f} Hz, "
          f"{c - 4} channels), file {8 * c * n / 1e6:.0f} MB of rows")
    print(f"period counters: {int(first)} .. {int(last)}, jumps: {jumps}")
    for key in ("overruns", "gaps", "lost_samples", "ring_high_water", "module.depth",
                "stop_reason"):
        print(f"{key}: {meta.get(key)}")
    expect(jumps == 0, f"{jumps} jump(s) in the period counter")
    expect(n == int(last - first) + 1, "rows differ from the periods they span")
    expect(expected <= n <= expected + 1000, f"{n} rows for {duration_s} s ({expected:.0f} expected)")
    expect(marker_off == 0, f"{marker_off} row(s) with the marker off while enable was held on")
    expect(worst_t < 1e-6, f"t differs from period x sample_period_s by {worst_t}")
    for key in ("overruns", "gaps", "lost_samples"):
        expect(meta.get(key) == "0", f"{key}: {meta.get(key)}")
    expect(int(pin_overruns) == 0, f"circlog.0.overruns pin: {pin_overruns}")
    expect(int(recorder_rc) == 0, f"recorder exit code {recorder_rc}")
    expect(meta.get("stop_reason") == "duration", f"stop_reason: {meta.get('stop_reason')}")
    for f in failures:
        print("FAIL:", f)
        print("FAIL:", f, file=sys.stderr)  # run-hal-test.sh shows stderr when a test fails
    print("soak:", "every sample recorded" if not failures else "FAILED")
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    {"signals": signals, "overruns": overruns, "runs": runs,
     "soak": soak}[sys.argv[1]](*sys.argv[2:])
