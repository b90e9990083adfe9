"""Debian's Chromium driven by Playwright, for the browser tests: skipped locally when either is
missing, a failure under CI=true (``.ci/run`` installs Chromium)."""
from __future__ import annotations

import contextlib
import os
import shutil

import pytest

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")
CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if os.path.exists("/usr/bin/chromium") else None)
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--no-first-run", "--autoplay-policy=no-user-gesture-required"]


def need(what: str, ok: bool):
    """Skip (locally) or fail (CI=true) when ``what`` is not available."""
    if ok:
        return
    if IN_CI:
        pytest.fail(f"CI=true but {what} is missing (the browser test must run in CI)")
    pytest.skip(f"{what} not available")


@contextlib.contextmanager
def chromium():
    """A launched Playwright Chromium browser (closed on exit)."""
    need("Chromium (/usr/bin/chromium; apt-get install chromium)", CHROMIUM is not None)
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        need("the playwright Python package", False)
    with sync_playwright() as p:
        br = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, timeout=60_000)
        try:
            yield br
        finally:
            br.close()
