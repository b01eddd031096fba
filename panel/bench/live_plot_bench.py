#!/usr/bin/python3
"""The live plot's cost on the GUI thread: a recorder's trace at 1 kHz x 6 channels (x_cmd,
y_cmd, x_fb, y_fb, x, y, with t, period, marker, segment) growing while the panel reads it
10 times a second and repaints the plot (offscreen).

  frames:   the whole test (default 600 s of samples) appended frame by frame as fast as the
            machine goes; the time of each frame's read + repaint is measured. CPU at 10
            frames/s = mean frame time x 10 / s.
  realtime: a writer process appends 100 rows every 100 ms for --seconds; the panel's timer
            runs at 10 Hz; the GUI process's own CPU time and the longest gap between two
            frames (a stall) are measured.
  catchup:  the panel opened with --backlog-s of samples already written: the longest single
            read (it reads at most 64 KiB per read).

usage: QT_QPA_PLATFORM=offscreen live_plot_bench.py [frames|realtime|catchup] [options]
"""
import argparse
import math
import os
import random
import resource
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "circtest"))
os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import circtest_live as live  # noqa: E402

RATE_HZ = 1000
RADIUS_MM = 50.0
RUN_S = 2 * math.pi * RADIUS_MM / 1000.0 * 60.0  # one turn at F1000: 18.85 s


def header():
    return ("# plane: XY\n# radius_mm: 50\n# centre_mm: 0,0,0\n# sample_period_s: 0.001\n"
            "t,period,x_cmd,y_cmd,x_fb,y_fb,x,y,marker,segment\n")


def rows(first, count, rng):
    out = []
    for i in range(first, first + count):
        t = i / RATE_HZ
        segment = int(t // RUN_S) + 1
        a = 2 * math.pi * (t % RUN_S) / RUN_S * (1 if segment % 2 else -1)
        r = RADIUS_MM + 0.005 * math.cos(2 * a) + rng.gauss(0, 0.0005)
        c, s = RADIUS_MM * math.cos(a), RADIUS_MM * math.sin(a)
        out.append("%.9f,%d,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,1,%d\n" % (
            t, i, c, s, c, s, r * math.cos(a), r * math.sin(a), segment))
    return "".join(out)


def make_plot():
    from PyQt5.QtWidgets import QApplication
    import circtest_widgets
    app = QApplication.instance() or QApplication([])
    plot = circtest_widgets.PolarPlot()
    plot.resize(600, 600)
    return app, plot


def frame(source, plot):
    source.poll()
    plot.set_polar(source.polar)
    plot.grab()  # a real paint into an image


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(p / 100.0 * len(values)))]


def bench_frames(args):
    app, plot = make_plot()
    rng = random.Random(1)
    path = os.path.join(tempfile.mkdtemp(prefix="circtest-bench-"), "live.csv")
    per_frame = RATE_HZ // 10
    times, cpu = [], []
    with open(path, "w") as out:
        out.write(header())
        source = live.LiveSource(path)
        for k in range(int(args.seconds * 10)):
            out.write(rows(k * per_frame, per_frame, rng))
            out.flush()
            t0, c0 = time.perf_counter(), time.process_time()
            frame(source, plot)
            times.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    mean = sum(cpu) / len(cpu)
    print("frames: %d s of samples, %d frames, %d rows, %d runs" % (
        args.seconds, len(times), source.rows, len(source.polar.runs)))
    print("frame CPU time: mean %.2f ms, p99 %.2f ms, max %.2f ms" % (
        mean * 1e3, percentile(cpu, 99) * 1e3, max(cpu) * 1e3))
    print("frame wall time: mean %.2f ms, p99 %.2f ms, max %.2f ms (load average %.1f)" % (
        sum(times) / len(times) * 1e3, percentile(times, 99) * 1e3, max(times) * 1e3,
        os.getloadavg()[0]))
    print("CPU at 10 frames/s: %.1f %% of one core" % (mean * 10 * 100))
    del app


def writer(path, seconds):
    rng = random.Random(2)
    with open(path, "a") as out:
        start = time.monotonic()
        for k in range(int(seconds * 10)):
            out.write(rows(k * 100, 100, rng))
            out.flush()
            time.sleep(max(0.0, start + (k + 1) * 0.1 - time.monotonic()))


def bench_realtime(args):
    from PyQt5.QtCore import QTimer
    app, plot = make_plot()
    path = os.path.join(tempfile.mkdtemp(prefix="circtest-bench-"), "live.csv")
    with open(path, "w") as out:
        out.write(header())
    proc = subprocess.Popen([sys.executable, __file__, "write", "--path", path, "--seconds",
                             str(args.seconds)])
    source = live.LiveSource(path)
    stamps = []
    timer = QTimer()
    timer.setInterval(100)
    timer.timeout.connect(lambda: (stamps.append(time.monotonic()), frame(source, plot)))
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t0 = time.monotonic()
    timer.start()
    watch = QTimer()
    watch.setInterval(200)
    watch.timeout.connect(lambda: proc.poll() is not None and app.quit())
    watch.start()
    app.exec_()
    timer.stop()
    wall = time.monotonic() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
    print("realtime: %.0f s, %d frames (%.1f/s), %d rows" % (wall, len(stamps),
                                                             len(stamps) / wall, source.rows))
    print("GUI process CPU: %.1f %% of one core" % (cpu / wall * 100))
    print("longest gap between frames: %.0f ms (100 ms planned)" % (max(gaps) * 1e3))


def bench_catchup(args):
    app, plot = make_plot()
    path = os.path.join(tempfile.mkdtemp(prefix="circtest-bench-"), "live.csv")
    with open(path, "w") as out:
        out.write(header())
        out.write(rows(0, int(args.backlog_s * RATE_HZ), random.Random(3)))
    source = live.LiveSource(path)
    times, cpu = [], []
    while True:
        t0, c0 = time.perf_counter(), time.process_time()
        frame(source, plot)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        if source.rows >= int(args.backlog_s * RATE_HZ):
            break
    print("catchup: %.0f s backlog read in %d reads; longest read + repaint: %.1f ms CPU, "
          "%.1f ms wall (load average %.1f)" % (args.backlog_s, len(times), max(cpu) * 1e3,
                                                max(times) * 1e3, os.getloadavg()[0]))
    del app


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("mode", choices=["frames", "realtime", "catchup", "write"])
    parser.add_argument("--seconds", type=float, default=600.0)
    parser.add_argument("--backlog-s", type=float, default=300.0)
    parser.add_argument("--path")
    args = parser.parse_args()
    if args.mode == "write":
        writer(args.path, args.seconds)
    else:
        {"frames": bench_frames, "realtime": bench_realtime,
         "catchup": bench_catchup}[args.mode](args)


if __name__ == "__main__":
    main()
