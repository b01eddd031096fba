"""The circtest panel's logic, without Qt: the command lines of the circtest programs, their
results read from their --json output, their errors as the one line they print.

The numbers on the panel are the programs' numbers: nothing here evaluates a circle. The
panel runs `circtest run` / `circtest verify` (the guided session, docs/session.md), reads the
session folder's results.json and diagnosis.json (circana's JSON) and asks `circcomp plan
--json` for the corrections.
"""
import json
import math
import os
import shutil
import subprocess
import tempfile

PROGRAMS = ("circgen", "circana", "circcomp", "circtest")
PLANES = ("XY", "YZ", "ZX")
# circtest run's defaults (docs/session.md): D100, F1000, XY.
DEFAULT_DIAMETER_MM = 100.0
DEFAULT_FEED_MM_PER_MIN = 1000.0
# The live plot's fixed scale (µm of deviation per division), as the report's plots compare.
DEFAULT_UM_PER_DIVISION = 5.0


class ProgramError(Exception):
    """A program that failed: its one-line message (as it printed it) and its exit code."""

    def __init__(self, message, exit_code):
        super().__init__(message)
        self.message = message
        self.exit_code = exit_code


def one_line_error(program, exit_code, stderr):
    """The line a failed program printed about its failure: its first `program: error:` line,
    else its last line on stderr, else what the exit code says."""
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    for line in lines:
        if ": error:" in line:
            return line
    if lines:
        return lines[-1]
    if exit_code < 0:
        return "%s: stopped by signal %d" % (program, -exit_code)
    return "%s: failed with exit code %d and no message" % (program, exit_code)


def find_programs(environ=None):
    """Where each program is: CIRCTEST_BINDIR (a folder holding them), else PATH."""
    environ = os.environ if environ is None else environ
    bindir = environ.get("CIRCTEST_BINDIR", "")
    found = {}
    for name in PROGRAMS:
        path = os.path.join(bindir, name) if bindir else shutil.which(name, path=environ.get(
            "PATH", os.defpath))
        if path and os.access(path, os.X_OK):
            found[name] = path
    return found


class Programs:
    """The programs' paths; a missing one is a ProgramError when it is needed."""

    def __init__(self, paths):
        self.paths = dict(paths)

    def path(self, name):
        if name not in self.paths:
            raise ProgramError("%s: not found: install circtest (docs/install.md) or set "
                               "CIRCTEST_BINDIR to the folder that holds it" % name, 127)
        return self.paths[name]


def _number_text(value):
    return ("%.6f" % value).rstrip("0").rstrip(".")


class Setup:
    """What the operator chose on the set-up step."""

    def __init__(self, ini="", planes=("XY",), diameter_mm=DEFAULT_DIAMETER_MM,
                 feeds_mm_per_min=(DEFAULT_FEED_MM_PER_MIN,), start=False, annex_c=None):
        self.ini = ini
        # ISO 230-4 Annex C: (reference diameter D2 mm, reference feed V2 mm/min); circgen
        # then computes the feed (circgen --ref-d/--ref-f), and the preview takes it over.
        self.annex_c = annex_c
        self.planes = tuple(planes)
        self.diameter_mm = float(diameter_mm)
        self.feeds_mm_per_min = tuple(float(f) for f in feeds_mm_per_min)
        self.start = start

    def check(self):
        """A set-up the programs would refuse for its form: the panel's own one-line message.
        The programs check the rest (limits, plausible ranges)."""
        if not self.planes or any(p not in PLANES for p in self.planes):
            raise ProgramError("circtest panel: error: choose one or more planes of XY, YZ, ZX",
                               2)
        if not (math.isfinite(self.diameter_mm) and self.diameter_mm > 0):
            raise ProgramError("circtest panel: error: the diameter must be a number above 0 mm",
                               2)
        if not self.feeds_mm_per_min or not all(
                math.isfinite(f) and f > 0 for f in self.feeds_mm_per_min):
            raise ProgramError("circtest panel: error: each feed must be a number above 0 "
                               "mm/min", 2)

    def circgen_feed_options(self):
        if self.annex_c:
            return ["--d", _number_text(self.diameter_mm), "--ref-d",
                    _number_text(self.annex_c[0]), "--ref-f", _number_text(self.annex_c[1]),
                    "--plane", ",".join(self.planes)]
        return self.program_options()

    def program_options(self):
        """The options circgen and `circtest run` share."""
        options = ["--d", _number_text(self.diameter_mm)]
        if len(self.feeds_mm_per_min) == 1:
            options += ["--f", _number_text(self.feeds_mm_per_min[0])]
        else:
            options += ["--feeds", ",".join(_number_text(f) for f in self.feeds_mm_per_min)]
        options += ["--plane", ",".join(self.planes)]
        return options


def program_feeds(header):
    """The feeds a circgen program runs at (its header), mm/min."""
    return [float(f) for f in header.get("feeds_mm_per_min", header.get(
        "feed_mm_per_min", "")).split(",") if f]


def parse_feeds(text):
    """'1000' or '500,1000,2000' as numbers; ProgramError for anything else."""
    try:
        feeds = [float(item) for item in text.split(",")]
    except ValueError:
        raise ProgramError("circtest panel: error: feeds: expected F or F1,F2,... in mm/min, "
                           "got '%s'" % text, 2) from None
    return feeds


# ---- command lines ------------------------------------------------------------------------

def circgen_command(programs, setup, output):
    argv = [programs.path("circgen")] + setup.circgen_feed_options() + ["-o", output]
    if setup.ini:
        argv += ["--ini", setup.ini]
    return argv


def circtest_run_command(programs, setup):
    """`circtest run` without --yes: it applies nothing; the panel applies after its own
    confirmation (circcomp apply)."""
    argv = [programs.path("circtest"), "run", "--ini", setup.ini] + setup.program_options()
    if setup.start:
        argv.append("--start")
    return argv


def circtest_verify_command(programs, setup):
    argv = [programs.path("circtest"), "verify", "--ini", setup.ini]
    if setup.start:
        argv.append("--start")
    return argv


def circana_analyze_command(programs, trace, columns=None):
    argv = [programs.path("circana"), "analyze", trace, "--json"]
    if columns:
        argv += ["--columns", columns]
    return argv


def circcomp_plan_command(programs, ini, diagnosis):
    return [programs.path("circcomp"), "plan", "--ini", ini, diagnosis, "--json"]


def circcomp_diff_command(programs, ini, diagnosis):
    return [programs.path("circcomp"), "plan", "--ini", ini, diagnosis]


def circcomp_apply_command(programs, ini, diagnosis):
    return [programs.path("circcomp"), "apply", "--ini", ini, diagnosis]


# ---- running ------------------------------------------------------------------------------

# `circtest verify` exits 9 (tolerance) when its test is not within the session's limits (OUT
# OF TOLERANCE, NOT DECIDED): its verdict, a result, printed after everything was written
# (docs/session.md), as `circana history --limits` exits 9.
TOLERANCE_EXIT = 9


def is_result_exit(argv, exit_code):
    """Whether ARGV's non-zero EXIT_CODE is a result: circtest verify's verdict."""
    return (exit_code == TOLERANCE_EXIT and os.path.basename(argv[0]) == "circtest"
            and argv[1:2] == ["verify"])


def verdict_line(stdout):
    """The verdict circtest run or verify printed (`circtest: verdict against LIMITS ...`,
    without `circtest: `), else None."""
    prefix = "circtest: verdict against "
    for line in stdout.splitlines():
        if line.startswith(prefix):
            return line[len("circtest: "):]
    return None


def finish(argv, exit_code, stdout, stderr):
    """A program's end: its stdout when it exited 0 (or with a result's exit code: circtest
    verify's 9), else ProgramError with its one line."""
    if exit_code != 0 and not is_result_exit(argv, exit_code):
        raise ProgramError(one_line_error(os.path.basename(argv[0]), exit_code, stderr),
                           exit_code)
    return stdout


def run(argv, timeout_s=None):
    """Runs ARGV to its end (for a worker thread or a test, never the GUI thread)."""
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=timeout_s,
                              stdin=subprocess.DEVNULL, check=False)
    except FileNotFoundError:
        raise ProgramError("%s: not found" % argv[0], 127) from None
    except subprocess.TimeoutExpired:
        raise ProgramError("%s: no answer within %g s" % (os.path.basename(argv[0]), timeout_s),
                           124) from None
    return finish(argv, done.returncode, done.stdout, done.stderr)


def parse_json(argv, text):
    try:
        return json.loads(text)
    except ValueError as exc:
        raise ProgramError("%s: its --json output is not JSON (%s)" % (
            os.path.basename(argv[0]), exc), 1) from None


def run_json(argv, timeout_s=None):
    return parse_json(argv, run(argv, timeout_s))


# ---- what the programs say ----------------------------------------------------------------

def _um(value_mm):
    return None if value_mm is None else value_mm * 1000.0


def _u_um(value_mm, u_mm):
    """U (k = 2) in µm beside a value; "not known" for a value whose document has no U."""
    if value_mm is None:
        return None
    return "not known" if u_mm is None else u_mm * 1000.0


def evaluations(document):
    """The evaluations in circana analyze --json: one, or a test set's planes."""
    if "planes" in document:
        return list(document["planes"])
    return [document]


def result_rows(document):
    """One row per run: plane, direction, feed, G and F (µm), and the H (µm) of its pair, each
    with its expanded uncertainty U (k = 2, µm). F is ISO 230-4's: the larger of |F_max| and
    |F_min|. Straight from circana's JSON, converted from mm to µm."""
    rows = []
    for ev in evaluations(document):
        pair_h = {}
        for pair in ev.get("pairs", []):
            for run_index in pair["runs"]:
                pair_h[run_index] = pair
        for index, run_result in enumerate(ev.get("runs", [])):
            f = None
            if run_result.get("F_max") is not None and run_result.get("F_min") is not None:
                f = max(abs(run_result["F_max"]), abs(run_result["F_min"]))
            pair = pair_h.get(index, {})
            rows.append({
                "plane": ev.get("plane", ""),
                "direction": run_result.get("direction", ""),
                "feed_mm_per_min": run_result.get("feed_mm_per_min"),
                "G_um": _um(run_result.get("G")),
                "U_G_um": _u_um(run_result.get("G"), run_result.get("U_G")),
                "F_um": _um(f),
                "U_F_um": _u_um(f, run_result.get("U_F")),
                "H_um": _um(pair.get("H")),
                "U_H_um": _u_um(pair.get("H"), pair.get("U_H", ev.get("U_H"))),
            })
    return rows


def contribution_rows(diagnosis):
    """The diagnosis's sources with their share of G, as circana diagnose --json ranks them."""
    return [{"source": c["source"], "G_um": _um(c.get("G_mm")), "percent": c.get("percent")}
            for c in diagnosis.get("contributions", [])]


def plan_lines(plan):
    """circcomp plan --json as readable lines: each change in circcomp's words, then its
    advice and notes."""
    lines = []
    for change in plan.get("changes", []):
        where = change.get("section") or os.path.basename(change.get("file") or "")
        mark = "" if change.get("effective", True) else " (no effect)"
        lines.append("[%s] %s%s" % (where, change.get("words", ""), mark))
    for key in ("summary", "advice", "notes"):
        for item in plan.get(key, []):
            lines.append(item if isinstance(item, str) else json.dumps(item))
    return lines


def session_folder(stdout_line):
    """The session folder `circtest run` (`circtest: session folder DIR`) or `circtest verify`
    (`circtest: verifying session DIR: its program again`) announces on a line, else None."""
    line = stdout_line.strip()
    prefix = "circtest: session folder "
    if line.startswith(prefix):
        return line[len(prefix):]
    prefix, suffix = "circtest: verifying session ", ": its program again"
    if line.startswith(prefix) and line.endswith(suffix):
        return line[len(prefix):-len(suffix)]
    return None


def write_apply_record(session_dir, apply_stdout):
    """circcomp apply's output into SESSION/apply.txt, as `circtest run` writes it (verify
    takes the latest session that has one): a temporary, fsync, rename."""
    path = os.path.join(session_dir, "apply.txt")
    fd, tmp = tempfile.mkstemp(prefix=".apply.", dir=session_dir)
    try:
        with os.fdopen(fd, "w") as out:
            out.write(apply_stdout)
            out.flush()
            os.fsync(out.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path


# ---- the program's header: the path preview -----------------------------------------------

def program_header(path):
    """The `(circtest: key: value)` comments circgen writes at the top of a program."""
    header = {}
    with open(path, encoding="utf-8", errors="replace") as program:
        for line in program:
            line = line.strip()
            if not (line.startswith("(circtest: ") and line.endswith(")")):
                break
            key, _, value = line[len("(circtest: "):-1].partition(": ")
            header[key.strip()] = value.strip()
    return header


def preview_path(header, points_per_turn=360):
    """The nominal path of the measured runs in the plane (first plane axis, second), mm:
    the arc from the start angle over the total angle circgen announces (leads included)."""
    radius = float(header["radius_mm"])
    centre = [float(v) for v in header.get("centre_mm", "0,0,0").split(",")]
    plane = header.get("plane", "XY").split(",")[0]
    first, second = {"XY": (0, 1), "YZ": (1, 2), "ZX": (2, 0)}[plane]
    start = math.radians(float(header.get("start_deg", "0")) - float(header.get("lead_deg",
                                                                               "0")))
    total = math.radians(float(header.get("arc_total_deg", header.get("arc_deg", "360"))))
    n = max(2, int(points_per_turn * total / (2 * math.pi)) + 1)
    return [(centre[first] + radius * math.cos(start + total * i / (n - 1)),
             centre[second] + radius * math.sin(start + total * i / (n - 1)))
            for i in range(n)]


# ---- LinuxCNC ------------------------------------------------------------------------------

def machine_state(linuxcnc_module):
    """One line on the machine from LinuxCNC's status channel (polled, never waited on; the
    error channel is the main screen's and is never read here)."""
    if linuxcnc_module is None:
        return "LinuxCNC's Python module is not installed (linuxcnc-uspace)"
    try:
        stat = linuxcnc_module.stat()
        stat.poll()
    except (linuxcnc_module.error, SystemError) as exc:
        # SystemError: LinuxCNC 2.9's poll() without a running LinuxCNC's tool table memory.
        return "no LinuxCNC runs (%s): start the machine first" % exc
    parts = []
    parts.append("E-stop" if stat.task_state == linuxcnc_module.STATE_ESTOP else (
        "on" if stat.task_state == linuxcnc_module.STATE_ON else "off"))
    homed = all(stat.homed[j] for j in range(stat.joints))
    parts.append("homed" if homed else "not homed")
    parts.append("idle" if stat.interp_state == linuxcnc_module.INTERP_IDLE else
                 "program running")
    return "LinuxCNC: " + ", ".join(parts)
