"""The headless Chromium of the report's browser test, shared with the live view's."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

_spec = importlib.util.spec_from_file_location("report_browser", Path(__file__).parents[1] / "report" / "conftest.py")
assert _spec is not None and _spec.loader is not None
report_browser = importlib.util.module_from_spec(_spec)
sys.modules["report_browser"] = report_browser
_spec.loader.exec_module(report_browser)

chromium = report_browser.chromium
