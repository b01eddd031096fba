"""The panel's Report and History steps offscreen (pytest-qt) with the real circana: the session's
report (its path, Open, page 1's verdict with H, G, F before and after and their U), circana's
before/after plot, the machine's history trend from `circana history --json`, and errors shown
as one line in the panel (never only a traceback on stderr)."""
import json
import os
import re
import stat

import pytest

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

from PyQt5.QtCore import QObject, QUrl, pyqtSlot  # noqa: E402
from PyQt5.QtGui import QDesktopServices  # noqa: E402

import circtest_logic as logic  # noqa: E402
import circtest_records as records  # noqa: E402
import circtest_widgets as widgets  # noqa: E402
import linuxcnc as fake_linuxcnc  # noqa: E402  (tests/fakes)
from conftest import simulate  # noqa: E402

REPORT_TAB, HISTORY_TAB = 4, 5


def script(path, text):
    path.write_text("#!/bin/sh\n" + text)
    path.chmod(path.stat().st_mode | stat.S_IXUSR)
    return str(path)


def make_panel(qtbot, programs, **replaced):
    panel = widgets.CircTestPanel(logic.Programs(dict(programs.paths, **replaced)),
                                  fake_linuxcnc, "machine.ini")
    qtbot.addWidget(panel)
    return panel


def traced(path, backlash_mm, machine="mill-3", start_time=None):
    """A simulated test (X backlash injected) with the metadata circlog-record writes."""
    simulate(path, "--d", "100", "--f", "1000", "--backlash-x", str(backlash_mm))
    head = "# machine: %s\n" % machine
    if start_time:
        head += "# start_time: %s\n" % start_time
    text = path.read_text()
    path.write_text(head + text)
    return str(path)


def analyze(programs, trace, *more):
    return logic.run_json([programs.path("circana"), "analyze", trace, "--json"] + list(more))


def session(tmp_path, programs, verify=True):
    """A session folder as circtest run (and verify) leave it, made by the real circana:
    10 µm of X backlash before, 2 µm after."""
    d = tmp_path / "session"
    d.mkdir()
    before = traced(d / "trace.csv", 0.01)
    (d / "results.json").write_text(json.dumps(analyze(programs, before)))
    report = [programs.path("circana"), "report"]
    if verify:
        after = traced(d / "verify-trace.csv", 0.002)
        (d / "verify-results.json").write_text(json.dumps(analyze(programs, after)))
        report += [after, before]
    else:
        report += [before]
    report += ["-o", str(d / "report.html")]
    logic.run(report)
    return d


def um(mm):
    return "%.1f µm" % (mm * 1000.0)


def verdict_rows(panel):
    table = panel.report_page.verdict
    header = [table.horizontalHeaderItem(j).text() for j in range(table.columnCount())]
    return [dict(zip(header, (table.item(i, j).text() for j in range(table.columnCount()))))
            for i in range(table.rowCount())]


def largest_g(document):
    return max(document["runs"], key=lambda r: r["G"])


def test_the_report_after_the_run_and_after_verify(qtbot, programs, tmp_path):
    d = session(tmp_path, programs, verify=False)
    panel = make_panel(qtbot, programs)
    panel.load_session(str(d))
    page = panel.report_page
    assert page.path_label.text() == "The report: %s" % (d / "report.html")
    assert panel.report_button.isEnabled()
    # After the run: this test alone, no before column; no before/after plot.
    run = analyze(programs, str(d / "trace.csv"))
    rows = {r["Quantity"]: r for r in verdict_rows(panel)}
    assert list(rows["H"]) == ["Plane", "Quantity", "this test", "U (k = 2)", "limit", "result"]
    assert rows["H"]["this test"] == um(run["H"]) == "10.0 µm"  # the injected backlash
    assert rows["H"]["U (k = 2)"] == um(run["U_H"])
    assert not page.plot_paths and page.g_label.text() == ""

    # After verify: the report of after and before, read again.
    for name in ("verify-trace.csv", "verify-results.json", "report.html"):
        (d / name).unlink(missing_ok=True)
    after_trace = traced(d / "verify-trace.csv", 0.002)
    after = analyze(programs, after_trace)
    (d / "verify-results.json").write_text(json.dumps(after))
    logic.run([programs.path("circana"), "report", after_trace, str(d / "trace.csv"), "-o",
               str(d / "report.html")])
    panel.load_session(str(d))
    rows = {r["Quantity"]: r for r in verdict_rows(panel)}
    assert rows["H"]["before"] == um(run["H"]) and rows["H"]["this test"] == um(after["H"])
    assert rows["H"]["this test"] == "2.0 µm"  # the 2 µm of backlash left
    assert rows["H"]["U (k = 2)"] == um(after["U_H"])
    assert rows["G"]["before"] == um(largest_g(run)["G"])
    assert rows["G"]["this test"] == um(largest_g(after)["G"])
    assert rows["G"]["U (k = 2)"] == um(largest_g(after)["U_G"])
    assert rows["F"]["this test"] == um(max(max(r["F_max"], -r["F_min"]) for r in after["runs"]))
    assert {r["result"] for r in rows.values()} == {"no limit set"}
    assert page.banner.text().startswith("<b>Verdict: no limit set</b> — No acceptance limits")

    # The before/after plot: circana's, both tests at one scale, G of each run in its legend.
    qtbot.waitUntil(lambda: "XY" in page.plot_paths, timeout=15000)
    svg = open(page.plot_paths["XY"]).read()
    for label, document in (("before", run), ("after", after)):
        for i, r in enumerate(document["runs"]):
            assert re.search(r"%s: run %d [^<]*G = %.1f um" % (label, i + 1, r["G"] * 1000), svg)
    assert "(dashed)" in svg and svg.count("1 division = ") == 1  # one scale for both
    assert page.g_label.text() == "XY: G before %s µm, after %s µm" % (
        ", ".join("%.1f" % (r["G"] * 1000) for r in run["runs"]),
        ", ".join("%.1f" % (r["G"] * 1000) for r in after["runs"]))
    assert page.findChild(widgets.QSvgWidget, "before-after-XY").renderer().isValid()


def test_the_verdict_against_limits(qtbot, programs, tmp_path):
    # The 10 µm of backlash against H 5 µm fails (H - U above it), G 0.5 mm passes (G + U below
    # it), and an F limit at F itself is within its U: not decided (ISO 14253-1).
    d = session(tmp_path, programs, verify=False)
    run = json.loads((d / "results.json").read_text())
    f_mm = max(max(r["F_max"], -r["F_min"]) for r in run["runs"])
    assert run["H"] - run["U_H"] > 0.005
    assert largest_g(run)["G"] + largest_g(run)["U_G"] <= 0.5
    assert run["U_H"] > 0 and largest_g(run)["U_F"] > 0
    logic.run([programs.path("circana"), "report", str(d / "trace.csv"), "-o",
               str(d / "report.html"), "--limits", "H=0.005,G=0.5,F=%.6f" % f_mm])
    panel = make_panel(qtbot, programs)
    panel.load_session(str(d))
    rows = {r["Quantity"]: r for r in verdict_rows(panel)}
    assert rows["H"]["result"] == "FAIL" and rows["H"]["limit"] == "5.0 µm"
    assert rows["G"]["result"] == "PASS" and rows["G"]["limit"] == "500.0 µm"
    assert rows["F"]["result"] == "not decided: within the uncertainty"
    assert panel.report_page.banner.text().startswith("<b>Verdict: FAIL</b> — Against the "
                                                      "agreed acceptance limits")


def test_open_the_report(qtbot, programs, tmp_path):
    d = session(tmp_path, programs, verify=False)
    panel = make_panel(qtbot, programs)
    panel.load_session(str(d))

    class Viewer(QObject):
        urls = []

        @pyqtSlot(QUrl)
        def show(self, url):
            self.urls.append(url.toLocalFile())

    viewer = Viewer()
    QDesktopServices.setUrlHandler("file", viewer, b"show")
    try:
        qtbot.mouseClick(panel.report_button, widgets.Qt.LeftButton)
        assert viewer.urls == [str(d / "report.html")]
        assert panel.status.text() == "opened in the desktop's viewer: %s" % (d / "report.html")
        (d / "report.html").unlink()
        qtbot.mouseClick(panel.report_button, widgets.Qt.LeftButton)
        assert panel.status.text() == ("circtest panel: error: %s: the report is not there (run "
                                       "the test again)" % (d / "report.html"))
        assert len(viewer.urls) == 1
    finally:
        QDesktopServices.unsetUrlHandler("file")


def stored(programs, tmp_path, machine, backlash_and_times):
    """Tests of MACHINE stored in the history as circtest run stores them (circana diagnose
    --store, circana's default database: under the test's XDG_DATA_HOME, conftest.py)."""
    traces = []
    for i, (backlash_mm, start_time) in enumerate(backlash_and_times):
        trace = traced(tmp_path / ("stored-%d.csv" % i), backlash_mm, machine, start_time)
        logic.run([programs.path("circana"), "diagnose", trace, "--store"])
        traces.append(trace)
    return traces


def test_history_trend_with_u(qtbot, programs, tmp_path):
    times = ["2026-03-01T08:00:00Z", "2026-03-02T08:00:00Z", "2026-03-05T08:00:00Z"]
    traces = stored(programs, tmp_path, "mill-3", zip((0.01, 0.006, 0.002), times))
    d = tmp_path / "session"
    d.mkdir()
    (d / "results.json").write_text(json.dumps(analyze(programs, traces[-1])))
    panel = make_panel(qtbot, programs)
    panel.load_session(str(d))
    page = panel.history_page
    qtbot.waitUntil(lambda: page.table.rowCount() == 3, timeout=15000)
    assert page.machine == "mill-3" and page.problem.text() == ""
    evaluations = [analyze(programs, t) for t in traces]
    for i, (ev, backlash_um) in enumerate(zip(evaluations, (10.0, 6.0, 2.0))):
        g = largest_g(ev)
        assert page.table.item(i, 0).text() == times[i]
        assert page.table.item(i, 3).text() == "%.1f ± %.1f" % (ev["H"] * 1000,
                                                               ev["U_H"] * 1000)
        assert page.table.item(i, 3).text().startswith("%.1f ±" % backlash_um)
        assert page.table.item(i, 4).text() == "%.1f ± %.1f" % (g["G"] * 1000, g["U_G"] * 1000)
    # The trend: x by time (1 day, then 3 days), y and U bars on one scale per quantity.
    page.trend.resize(500, 300)
    series = page.trend.series()
    xs = [p[0] for p in series["H"][2]]
    assert (xs[2] - xs[1]) == pytest.approx(3 * (xs[1] - xs[0]))
    for key in ("H", "G"):
        rect, top, points = series[key]
        px_per_um = rect.height() / top
        for (x, y, y_low, y_high, plane), ev in zip(points, evaluations):
            value = ev["H"] if key == "H" else largest_g(ev)["G"]
            u = ev["U_H"] if key == "H" else largest_g(ev)["U_G"]
            assert rect.bottom() - y == pytest.approx(value * 1000 * px_per_um)
            assert y_low - y_high == pytest.approx(
                (value + u - max(0.0, value - u)) * 1000 * px_per_um)
            assert plane == "XY"
    image = page.trend.grab().toImage()
    x, y = int(xs[0]), int(series["H"][2][0][1])
    assert image.pixelColor(x, y).name() != "#ffffff"  # the first test's point is drawn


def test_history_of_the_ini_machine_before_any_test(qtbot, programs, tmp_path, sim_servo):
    # configs/sim-servo's [EMC] MACHINE, under which circtest run stores its tests
    stored(programs, tmp_path, "circtest-sim-servo", [(0.004, "2026-03-01T08:00:00Z")])
    panel = make_panel(qtbot, programs)
    assert panel.history_page.machine is None  # "machine.ini" is no file: nothing asked
    qtbot.mouseClick(panel.history_page.refresh_button, widgets.Qt.LeftButton)
    assert panel.history_page.problem.text() == ("circtest panel: error: no machine yet: give "
                                                 "the machine's INI on the set-up step, or run "
                                                 "a test")
    panel = widgets.CircTestPanel(programs, fake_linuxcnc, sim_servo)
    qtbot.addWidget(panel)
    page = panel.history_page
    qtbot.waitUntil(lambda: page.table.rowCount() == 1, timeout=15000)
    assert page.machine == "circtest-sim-servo"
    assert page.table.item(0, 3).text().startswith("4.0 ± ")


def test_history_refusals_are_one_line(qtbot, programs, tmp_path):
    stored(programs, tmp_path, "mill-3", [(0.01, "2026-03-01T08:00:00Z")])
    d = tmp_path / "session"
    d.mkdir()
    trace = traced(d / "trace.csv", 0.01, machine="lathe-1")
    (d / "results.json").write_text(json.dumps(analyze(programs, trace)))
    panel = make_panel(qtbot, programs)
    panel.say("the test ended: results below")
    panel.load_session(str(d))
    page = panel.history_page
    qtbot.waitUntil(lambda: page.problem.text() != "", timeout=15000)
    assert page.problem.text().startswith("circana: error: ")
    assert "mill-3" in page.problem.text()  # circana names the machines it holds
    assert panel.status.text() == "the test ended: results below"  # the run's line stays
    # A test that names no machine: said on the step.
    trace = simulate(d / "trace.csv", "--d", "100", "--f", "1000")
    (d / "results.json").write_text(json.dumps(analyze(programs, trace)))
    panel.load_session(str(d))
    assert page.problem.text() == ("circtest panel: error: %s: the test names no machine, and "
                                   "the history is kept per machine" % d)


def test_errors_are_shown_in_the_panel(qtbot, programs, tmp_path):
    # circgen ends well but writes no program: the panel says so in one line.
    silent = script(tmp_path / "circgen", "exit 0\n")
    panel = make_panel(qtbot, programs, circgen=silent)
    qtbot.mouseClick(panel.preview_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.status.text() != "", timeout=10000)
    assert panel.status.text() == "circtest panel: error: %s: No such file or directory" % (
        os.path.join(panel.scratch.name, "preview.ngc"))
    assert panel.run_button.isEnabled()

    # A report that is not circana's, and the run's trace gone (circana cannot draw the
    # before/after plot): each one line on the Report step.
    d = session(tmp_path, programs)
    (d / "report.html").write_text("<html><body>something else</body></html>")
    (d / "trace.csv").unlink()
    panel.load_session(str(d))
    page = panel.report_page
    assert page.problem.text() == ("circtest panel: error: %s: no verdict on its first page (not "
                                   "a report of circana report)" % (d / "report.html"))
    first = page.problem.text()
    qtbot.waitUntil(lambda: page.problem.text() != first, timeout=15000)
    assert page.problem.text() == first + ("\ncircana: error: %s: cannot open: No such file or "
                                           "directory" % (d / "trace.csv"))

    # A results file the panel cannot read: its name and the system's words.
    (d / "results.json").unlink()
    (d / "results.json").mkdir()
    panel.load_session(str(d))
    assert panel.status.text() == "circtest panel: error: %s: Is a directory" % (
        d / "results.json")


def test_records_read_circanas_report(programs, tmp_path):
    d = session(tmp_path, programs)
    verdict = records.report_verdict(str(d / "report.html"))
    assert verdict["verdict"] == "NONE"
    assert [row[:2] for row in verdict["rows"]] == [["XY", "H"], ["XY", "G"], ["XY", "F"]]


@pytest.mark.skipif(records.chromium_path() is None,
                    reason="chromium not installed (Debian package chromium): no PDF print")
def test_save_the_report_as_pdf(qtbot, programs, tmp_path):
    import subprocess
    d = session(tmp_path, programs)
    after = json.loads((d / "verify-results.json").read_text())
    panel = make_panel(qtbot, programs)
    panel.load_session(str(d))
    assert panel.report_page.pdf_button.isEnabled()
    qtbot.mouseClick(panel.report_page.pdf_button, widgets.Qt.LeftButton)
    qtbot.waitUntil(lambda: panel.report_page.pdf_button.isEnabled(), timeout=120000)
    assert panel.status.text() == "the report as PDF: %s" % (d / "report.pdf")
    assert (d / "report.pdf").read_bytes()[:5] == b"%PDF-"
    assert not (d / ".report-printing.pdf").exists()
    # page 1 of the PDF is the report's hand-over page, with H after as circana gives it
    page1 = subprocess.run(["pdftotext", "-l", "1", str(d / "report.pdf"), "-"],
                           capture_output=True, text=True, check=True).stdout
    assert "hand-over report" in page1 and "Verdict: no limit set" in page1
    assert "%.1f µm" % (after["H"] * 1000) in page1
    # the report gone: said, nothing printed
    (d / "report.pdf").unlink()
    (d / "report.html").unlink()
    qtbot.mouseClick(panel.report_page.pdf_button, widgets.Qt.LeftButton)
    assert panel.status.text().endswith("report.html: the report is not there (run the test "
                                        "again)")
    assert not (d / "report.pdf").exists()
