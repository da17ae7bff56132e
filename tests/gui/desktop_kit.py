"""What every desktop screenshot script (``desktop_*.py``, run by ``qgis --code``) needs: the paths, a report, a
screenshot, a clean exit, and steps whose exceptions end the session with the traceback in the report.

Not a pytest module. ``MONOPLOT_REPO`` = the checkout (as tests/gui/run_desktop_aletsch.sh sets it).
"""

import json
import os
import sys
import traceback
from pathlib import Path

import qgis.utils
from qgis.core import QgsApplication, QgsProject
from qgis.PyQt.QtCore import QTimer

ROOT = Path(os.environ["MONOPLOT_REPO"])
DATA = ROOT.parent / "shared" / "data" / "aletsch"
OUT = ROOT / "test-artifacts"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


class DesktopSession:
    """One script's report (``test-artifacts/<name>_session.json``) and its screenshots."""

    def __init__(self, name: str, **fields):
        OUT.mkdir(exist_ok=True)
        self.name = name
        self.iface = qgis.utils.iface
        self.report = {"steps": [], "errors": [], **fields}

    def shot(self, name, widget=None):
        QgsApplication.processEvents()
        (widget or self.iface.mainWindow()).grab().save(str(OUT / name))
        self.report["steps"].append(name)

    def finish(self):
        (OUT / f"{self.name}_session.json").write_text(json.dumps(self.report, indent=1))
        QgsProject.instance().setDirty(False)
        QTimer.singleShot(300, lambda: os._exit(0))

    def guarded(self, fn):
        def run(*args):
            try:
                fn(*args)
            except Exception:  # noqa: BLE001
                self.report["errors"].append(traceback.format_exc())
                print(traceback.format_exc(), flush=True)
                self.finish()
        return run
