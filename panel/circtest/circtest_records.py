"""The panel's report, before/after plot and history, without Qt: the hand-over report's page-1
verdict as `circana report` wrote it, the command of circana's before/after plot, the machine's
history as `circana history --json` lists it.

As circtest_logic: nothing here evaluates a circle; every figure is one a program wrote.
"""
import datetime
import html.parser
import json
import os
import pathlib
import shutil

import circtest_logic as logic


def panel_error(text):
    return logic.ProgramError("circtest panel: error: " + text, 1)


def error_line(exc):
    """Any exception as the one line the panel shows (never a traceback): a program's own line,
    a file's name and what the system said, else the exception's kind and text."""
    if isinstance(exc, logic.ProgramError):
        return exc.message
    if isinstance(exc, OSError):
        where = exc.filename or ""
        return "circtest panel: error: %s%s" % (where + ": " if where else "",
                                                exc.strerror or exc)
    return "circtest panel: error: %s: %s" % (type(exc).__name__, exc)


def read_json_file(path, program="circana"):
    """A program's --json output that a session kept in a file."""
    with open(path, encoding="utf-8") as f:
        return logic.parse_json([program], f.read())


# ---- the report's first page: its verdict ---------------------------------------------------

class _VerdictReader(html.parser.HTMLParser):
    """The banner (`div.banner` with `data-verdict`) and the table `table.verdict` of page 1 of
    circana report: its header cells and each `tr.verdict-line`'s cells, as their text."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.verdict = None
        self.banner = []
        self.note = []
        self.header = []
        self.rows = []
        self._in = None  # "banner", "note", "th", "td"
        self._in_table = False
        self._cell = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        classes = (attrs.get("class") or "").split()
        if tag == "div" and "banner" in classes and self.verdict is None:
            self.verdict = attrs.get("data-verdict", "")
            self._in = "banner"
        elif tag == "small" and self._in == "banner":
            self._in = "note"
        elif tag == "table" and "verdict" in classes:
            self._in_table = True
        elif self._in_table and tag == "tr" and "verdict-line" in classes:
            self.rows.append([])
        elif self._in_table and tag in ("th", "td"):
            self._in, self._cell = tag, []

    def handle_endtag(self, tag):
        if tag == "div" and self._in in ("banner", "note"):
            self._in = None
        elif tag == "small" and self._in == "note":
            self._in = "banner"
        elif tag == "table" and self._in_table:
            self._in_table = False
        elif tag in ("th", "td") and self._in == tag:
            text = " ".join("".join(self._cell).split())
            if tag == "th":
                self.header.append(text)
            elif self.rows:
                self.rows[-1].append(text)
            self._in = None

    def handle_data(self, data):
        if self._in == "banner":
            self.banner.append(data)
        elif self._in == "note":
            self.note.append(data)
        elif self._in in ("th", "td"):
            self._cell.append(data)


def report_verdict(path):
    """Page 1 of a circana report: {"verdict": PASS|FAIL|OPEN|NONE, "banner": "Verdict: ...",
    "note": ..., "header": [Plane, Quantity, (before,) this test, U (k = 2), limit, result],
    "rows": [[...], ...]}, each cell as the report prints it (µm with one decimal)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        reader = _VerdictReader()
        reader.feed(f.read())
    if reader.verdict is None or not reader.header:
        raise panel_error("%s: no verdict on its first page (not a report of circana report)"
                          % path)
    return {"verdict": reader.verdict, "banner": " ".join("".join(reader.banner).split()),
            "note": " ".join("".join(reader.note).split()), "header": reader.header,
            "rows": reader.rows}


# ---- the report as PDF: printed by Chromium, as docs/html-report.md prints it ---------------

def chromium_path():
    """Debian's chromium (its headless print makes the report's A4 pages), else None."""
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


def pdf_command(chromium, html_path, pdf_path):
    argv = [chromium, "--headless", "--disable-gpu", "--no-pdf-header-footer",
            "--print-to-pdf=" + pdf_path, pathlib.Path(html_path).absolute().as_uri()]
    if os.geteuid() == 0:
        argv.insert(1, "--no-sandbox")  # Chromium starts as root only without its sandbox
    return argv


def pdf_written(partial, pdf_path):
    """The PDF Chromium printed into PARTIAL, renamed to PDF_PATH once it is one (a print that
    ended without one leaves nothing, and says so)."""
    try:
        with open(partial, "rb") as f:
            whole = f.read(5) == b"%PDF-"
    except OSError:
        whole = False
    if not whole:
        if os.path.exists(partial):
            os.unlink(partial)
        raise panel_error("chromium: no PDF written for %s" % pdf_path)
    os.replace(partial, pdf_path)
    return pdf_path


# ---- before and after: circana's plot of both tests at one scale -----------------------------

def before_after_commands(programs, session_dir, out_dir):
    """`circana analyze verify-trace.csv --compare trace.csv --svg FILE` per plane of the
    verify's evaluation (verify-results.json), on the channels it evaluated: [(plane, svg,
    argv)]. Empty before a verify."""
    results = os.path.join(session_dir, "verify-results.json")
    after = os.path.join(session_dir, "verify-trace.csv")
    if not (os.path.exists(results) and os.path.exists(after)):
        return []
    document = read_json_file(results)
    test_set = "planes" in document
    commands = []
    for ev in logic.evaluations(document):
        plane = ev.get("plane") or "XY"
        svg = os.path.join(out_dir, "before-after-%s.svg" % plane)
        argv = [programs.path("circana"), "analyze", after, "--compare",
                os.path.join(session_dir, "trace.csv"), "--svg", svg]
        if ev.get("channels"):
            argv += ["--columns", ",".join(ev["channels"])]
        if test_set:
            argv += ["--plane", plane]
        commands.append((plane, svg, argv))
    return commands


def g_before_after(session_dir):
    """Per plane, the G of each run before (results.json) and after (verify-results.json), µm:
    {plane: ([G before...], [G after...])}."""
    figures = {}
    for name, side in (("results.json", 0), ("verify-results.json", 1)):
        path = os.path.join(session_dir, name)
        if not os.path.exists(path):
            continue
        for row in logic.result_rows(read_json_file(path)):
            figures.setdefault(row["plane"] or "XY", ([], []))[side].append(row["G_um"])
    return figures


def g_before_after_text(figures):
    def um(values):
        return ", ".join("%.1f" % v for v in values if v is not None) or "–"
    return "; ".join("%s: G before %s µm, after %s µm" % (plane, um(b), um(a))
                     for plane, (b, a) in sorted(figures.items()))


# ---- the machine's history ------------------------------------------------------------------

def session_machine(session_dir):
    """The machine a session's test is stored under: its trace's `machine` condition as circana
    read it (results.json), else None."""
    path = os.path.join(session_dir, "results.json")
    if not os.path.exists(path):
        return None
    for ev in logic.evaluations(read_json_file(path)):
        machine = (ev.get("conditions") or {}).get("machine")
        if machine:
            return machine
    return None


def ini_machine(linuxcnc_module, ini_path):
    """The name `circtest run` stores the machine's tests under: the INI's [EMC] MACHINE, as
    LinuxCNC's own INI reader (the `linuxcnc` module's `ini`, which the screens use) reads it,
    else "machine"; None without an INI file or LinuxCNC's module."""
    if (not ini_path or linuxcnc_module is None or not hasattr(linuxcnc_module, "ini")
            or not os.path.isfile(ini_path)):
        return None
    try:
        return linuxcnc_module.ini(ini_path).find("EMC", "MACHINE") or "machine"
    except linuxcnc_module.error as exc:
        raise panel_error("%s: LinuxCNC's INI reader: %s" % (ini_path, exc)) from None


def circana_history_command(programs, machine):
    return [programs.path("circana"), "history", "--machine", machine, "--json"]


def tested_at_seconds(text):
    """A stored test time (a date, or a UTC date-time ending in Z) as seconds since 1970, or
    None when it is neither."""
    try:
        if len(text) == 10:
            moment = datetime.datetime.strptime(text, "%Y-%m-%d")
            moment = moment.replace(tzinfo=datetime.timezone.utc)
        else:
            moment = datetime.datetime.fromisoformat(text.replace("Z", "+00:00"))
            if moment.tzinfo is None:
                moment = moment.replace(tzinfo=datetime.timezone.utc)
    except ValueError:
        return None
    return moment.timestamp()


def history_tests(document):
    """circtest.history/1 as rows, oldest first: id, tested_at, plane, and H, G, F with their U
    (k = 2), in µm (None where the history holds none)."""
    if document.get("schema") != "circtest.history/1":
        raise panel_error("circana history: expected a circtest.history/1 document, got %s"
                          % json.dumps(document.get("schema")))
    rows = []
    for test in document.get("tests", []):
        row = {"id": test.get("id"), "tested_at": test.get("tested_at", ""),
               "plane": test.get("plane", "")}
        for key in ("H", "G", "F", "U_H", "U_G", "U_F"):
            value = test.get(key)
            row[key + "_um"] = None if value is None else value * 1000.0
        rows.append(row)
    return rows
