"""The live plot's data, without Qt: a trace file read while it grows (docs/trace-format.md:
`# key: value` metadata, the column header, rows), each new row turned into a polar
deviation from the nominal circle, kept per run in fixed angle bins so that drawing costs the
same at the first second and after ten minutes.

The deviation is the one circana's plot draws (analysis/src/render/plot.cpp):
hypot(a - centre_a, b - centre_b) - radius, at the angle atan2(b - centre_b, a - centre_a),
with the trace's nominal centre (`centre_machine_mm`, else `centre_mm`, x,y,z: the
positions are machine coordinates) and radius (`radius_mm`, or
`diameter_mm` / 2), on the plane's columns (`x,y` for XY, `y,z` for YZ, `z,x` for ZX; the
motor feedback `x_fb,y_fb` where the instrument columns are absent, as circtest evaluates).
The final numbers are circana's (circtest run writes them to results.json): the plot is what
the operator watches while the circle is drawn.
"""
import math
import os

PLANE_AXES = {"XY": ("x", "y"), "YZ": ("y", "z"), "ZX": ("z", "x")}


class TraceTail:
    """Reads what has been appended to a trace file since the last poll. A partial last line
    waits for the next poll; a file that was replaced or shortened is read again from its
    start (reset() is then called on the consumer through `restarted`)."""

    def __init__(self, path, max_bytes_per_poll=1 << 16):
        self.path = path
        self.max_bytes_per_poll = max_bytes_per_poll
        self._reset()

    def _reset(self):
        self.offset = 0
        self.partial = b""
        self.metadata = {}
        self.columns = None
        self.inode = None
        self.restarted = False
        self.behind = False  # more was written than the last poll read

    def poll(self):
        """The rows appended since the last call (lists of floats), at most about
        max_bytes_per_poll bytes' worth: the rest comes with the next call."""
        self.restarted = False
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return []
        if self.inode is not None and (st.st_ino != self.inode or st.st_size < self.offset):
            self._reset()
            self.restarted = True
        self.inode = st.st_ino
        if st.st_size <= self.offset:
            return []
        with open(self.path, "rb") as trace:
            trace.seek(self.offset)
            data = trace.read(self.max_bytes_per_poll)
        self.offset += len(data)
        self.behind = self.offset < st.st_size
        data = self.partial + data
        cut = data.rfind(b"\n") + 1
        self.partial = data[cut:]
        return self._parse(data[:cut].decode("utf-8", errors="replace").splitlines())

    def _parse(self, lines):
        rows = []
        for line in lines:
            line = line.strip()
            if not line:
                continue
            if line.startswith("#"):
                key, colon, value = line[1:].partition(":")
                if colon:
                    self.metadata[key.strip()] = value.strip()
                continue
            if self.columns is None:
                self.columns = [name.strip().strip('"') for name in line.split(",")]
                continue
            try:
                rows.append([float(field) for field in line.split(",")])
            except ValueError:
                continue  # the recorder writes numbers only; a torn line is skipped
        return rows


class RunPolar:
    """One run's deviations: per angle bin the lowest and highest deviation (µm), so that a
    spike is never averaged away."""

    def __init__(self, segment, bins):
        self.segment = segment
        self.low_um = [math.inf] * bins
        self.high_um = [-math.inf] * bins
        self.samples = 0
        self.plane = None
        self.last = None  # (angle rad, deviation µm) of the latest sample

    def extremes_um(self):
        filled = [(lo, hi) for lo, hi in zip(self.low_um, self.high_um) if lo <= hi]
        if not filled:
            return None
        return min(lo for lo, _ in filled), max(hi for _, hi in filled)


class LivePolar:
    """The runs of a trace as polar deviations, fed with TraceTail's rows."""

    def __init__(self, bins=720):
        self.bins = bins
        self.runs = []
        self.plane = None
        self.centre_ab = None
        self.radius_mm = None
        self._index = None
        self._planes = {}  # plane -> (column a, column b, centre a, centre b)
        self._segment_plane = {}
        self._announced = 0

    def reset(self):
        self.__init__(self.bins)

    def configure(self, metadata, columns):
        """Planes, centre, radius and column indices from the trace's metadata and header;
        None when ready, else what is missing (the plot then waits). A test set's trace
        (`plane: XY,YZ,ZX`) names each run's plane in `segments` (1:CCW:F500:XY,...)."""
        planes = [p.strip().upper() for p in metadata.get("plane", "XY").split(",")]
        for plane in planes:
            if plane not in PLANE_AXES:
                return "the trace's plane '%s' is not XY, YZ or ZX" % plane
        try:
            if "radius_mm" in metadata:
                radius = float(metadata["radius_mm"])
            else:
                radius = float(metadata["diameter_mm"]) / 2.0
            # Recorded positions are LinuxCNC's joint positions, machine coordinates: the centre
            # there (centre_machine_mm, circgen's when it knows the work offset) before the
            # program's (centre_mm, in its work offset), as circana takes them.
            centre_text = metadata.get("centre_machine_mm", metadata.get("centre_mm", "0,0,0"))
            centre = [float(v) for v in centre_text.split(",")]
            if len(centre) != 3:
                raise ValueError
        except (KeyError, ValueError):
            return "the trace names no nominal radius (radius_mm) or centre (centre_mm x,y,z)"
        axis = {"x": 0, "y": 1, "z": 2}
        self._planes = {}
        for plane in planes:
            a, b = PLANE_AXES[plane]
            if a not in columns or b not in columns:
                a, b = a + "_fb", b + "_fb"
            if a not in columns or b not in columns:
                return "the trace has no %s columns" % "/".join(PLANE_AXES[plane])
            self._planes[plane] = (columns.index(a), columns.index(b), centre[axis[a[0]]],
                                   centre[axis[b[0]]])
        segments = [e.split(":") for e in metadata.get("segments", "").split(",") if e]
        self._segment_plane = {}
        for entry in segments:
            if len(entry) == 4 and entry[0].strip().isdigit():
                self._segment_plane[int(entry[0])] = entry[3].strip().upper()
        self.plane = planes[0]
        self.radius_mm = radius
        self.centre_ab = self._planes[self.plane][2:]
        self._index = (columns.index("marker") if "marker" in columns else None,
                       columns.index("segment") if "segment" in columns else None)
        self._announced = len(segments)
        return None

    @property
    def runs_announced(self):
        return self._announced

    def _new_run(self, segment):
        run = RunPolar(segment, self.bins)
        run.plane = self._segment_plane.get(segment, self.plane)
        if run.plane not in self._planes:
            run.plane = self.plane
        self.runs.append(run)
        return run

    def add(self, rows):
        """Adds rows; only those inside a measured run (marker 1) when the trace marks runs."""
        if self._index is None:
            return
        im, iseg = self._index
        radius = self.radius_mm
        scale = self.bins / (2.0 * math.pi)
        run = self.runs[-1] if self.runs else None
        ia, ib, ca, cb = self._planes[run.plane] if run else (0, 0, 0.0, 0.0)
        for row in rows:
            if im is not None and row[im] != 1.0:
                if run is not None and iseg is None:
                    run = None  # without segment ids a run ends where the marker does
                continue
            segment = int(row[iseg]) if iseg is not None else len(self.runs) + (run is None)
            if run is None or run.segment != segment:
                run = self._new_run(segment)
                ia, ib, ca, cb = self._planes[run.plane]
            da, db = row[ia] - ca, row[ib] - cb
            angle = math.atan2(db, da)
            dev_um = (math.hypot(da, db) - radius) * 1000.0
            k = int((angle % (2.0 * math.pi)) * scale) % self.bins
            if dev_um < run.low_um[k]:
                run.low_um[k] = dev_um
            if dev_um > run.high_um[k]:
                run.high_um[k] = dev_um
            run.samples += 1
            run.last = (angle, dev_um)


class LiveSource:
    """A TraceTail and a LivePolar together: poll() reads what is new and returns the number of
    rows taken; `status` says what the plot waits for."""

    def __init__(self, path, bins=720):
        self.tail = TraceTail(path)
        self.polar = LivePolar(bins)
        self.status = "waiting for %s" % path
        self.rows = 0

    def poll(self):
        rows = self.tail.poll()
        if self.tail.restarted:
            self.polar.reset()
            self.rows = 0
        if self.tail.columns is None:
            return 0
        if self.polar._index is None:
            missing = self.polar.configure(self.tail.metadata, self.tail.columns)
            if missing:
                self.status = missing
                return 0
        self.polar.add(rows)
        self.rows += len(rows)
        n = self.polar.runs_announced
        self.status = "run %d of %s" % (len(self.polar.runs), n if n else "?")
        return len(rows)
