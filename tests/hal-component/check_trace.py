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


def signals(trace, sampler):
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
    print("about 5 s of periods:", yes(4000 <= len(on) <= 6500))
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


if __name__ == "__main__":
    {"signals": signals, "overruns": overruns, "runs": runs}[sys.argv[1]](*sys.argv[2:])
