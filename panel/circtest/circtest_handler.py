"""qtvcp handler of the circtest panel (`qtvcp circtest`, `qtvcp -x XID circtest`, or a
QtDragon/qtaxis tab through [DISPLAY] EMBED_TAB_*). It puts the panel (circtest_widgets) into
circtest.ui's layout; the logic is circtest_logic, the live plot's data circtest_live."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from PyQt5.QtCore import QTimer  # noqa: E402

import circtest_logic  # noqa: E402
import circtest_widgets  # noqa: E402

try:
    import linuxcnc
except ImportError:
    linuxcnc = None


class HandlerClass:
    def __init__(self, halcomp, widgets, paths):
        self.h = halcomp
        self.w = widgets
        self.paths = paths
        self.panel = None

    def initialized__(self):
        self.panel = circtest_widgets.CircTestPanel(
            circtest_logic.Programs(circtest_logic.find_programs()), linuxcnc,
            os.environ.get("INI_FILE_NAME", ""))
        self.w.panel_layout.addWidget(self.panel)
        # For tests and the documentation's pictures: the window as a PNG once it is shown.
        shot = os.environ.get("CIRCTEST_PANEL_SCREENSHOT")
        if shot:
            QTimer.singleShot(1500, lambda: self.w.grab().save(shot))

    def __getitem__(self, item):
        return getattr(self, item)

    def __setitem__(self, item, value):
        return setattr(self, item, value)


def get_handlers(halcomp, widgets, paths):
    return [HandlerClass(halcomp, widgets, paths)]
