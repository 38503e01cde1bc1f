"""What the browser tests share: the real ``vectorid ui`` server on a free port, a headless
Chromium driven by Selenium, and bounded waits. Screenshots go to test-artifacts/
(git-ignored). Importing this module skips the caller when dash, selenium or Chromium is
missing."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

pytest.importorskip("dash", reason="the UI needs the ui extra (dash): pip install 'vectorid[ui]'")
pytest.importorskip("selenium", reason="the browser tests need selenium")

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
if not (CHROMIUM and CHROMEDRIVER):
    pytest.skip(
        "headless Chromium is needed (Debian: apt-get install chromium chromium-driver)",
        allow_module_level=True,
    )

from selenium import webdriver  # noqa: E402
from selenium.common.exceptions import (  # noqa: E402
    NoSuchElementException,
    StaleElementReferenceException,
    TimeoutException,
)
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

__all__ = [
    "ARTIFACTS",
    "WAIT",
    "ActionChains",
    "By",
    "Keys",
    "NoSuchElementException",
    "StaleElementReferenceException",
    "TimeoutException",
    "WebDriverWait",
    "by_id",
    "chrome",
    "serve",
    "tab",
    "text_of",
    "type_into",
    "until",
]

WAIT = 40  # seconds, for any one thing to appear


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def serve(store: Path, folder: Path) -> Iterator[str]:
    """Run ``vectorid ui STORE`` on 127.0.0.1 and a free port while the context lasts;
    gives the page's URL. Fails the test with the server's log if it does not
    start, and checks at the end that the log holds no traceback."""
    port = free_port()
    env = dict(
        os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")
    )
    log = open(folder / "server.log", "w+b")
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "vectorid.cli",
            "ui",
            str(store),
            "--port",
            str(port),
            "--executor",
            "serial",
        ],
        stdout=log,
        stderr=subprocess.STDOUT,
        env=env,
        cwd=folder,
    )
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2) as r:
                if r.status == 200:
                    break
        except OSError:
            pass
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            log.seek(0)
            pytest.fail("vectorid ui did not start:\n" + log.read().decode(errors="replace"))
        time.sleep(0.3)
    try:
        yield url
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
    log.seek(0)
    text = log.read().decode(errors="replace")
    log.close()
    assert "Traceback" not in text, text


@contextmanager
def chrome(url: str, size: str = "1500,1400") -> Iterator[webdriver.Chrome]:
    """A headless Chromium on ``url`` (own profile, removed after) while the context
    lasts; gives the driver."""
    opts = webdriver.ChromeOptions()
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        f"--window-size={size}",
    ):
        opts.add_argument(flag)
    profile = tempfile.mkdtemp(prefix="vectorid-ui-chrome-")
    opts.add_argument(f"--user-data-dir={profile}")
    opts.binary_location = CHROMIUM
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})  # console errors: get_log
    drv = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    drv.set_page_load_timeout(WAIT)
    drv.get(url)
    ARTIFACTS.mkdir(exist_ok=True)
    try:
        yield drv
    finally:
        drv.quit()
        shutil.rmtree(profile, ignore_errors=True)


def text_of(drv, css: str) -> str:
    """The text of the first element matching ``css`` ("" if none), re-found if Dash
    re-renders it while it is read."""
    for attempt in range(5):
        try:
            els = drv.find_elements(By.CSS_SELECTOR, css)
            return els[0].text if els else ""
        except StaleElementReferenceException:
            if attempt == 4:
                raise
            time.sleep(0.1)
    return ""  # pragma: no cover - the loop returns or raises


def until(drv, fn, what: str, wait: float = WAIT):
    return WebDriverWait(
        drv,
        wait,
        poll_frequency=0.2,
        ignored_exceptions=(StaleElementReferenceException, NoSuchElementException),
    ).until(lambda d: fn(d), message=f"timed out waiting for {what}")


def type_into(drv, locate, text: str) -> None:
    """Replace the text of the field ``locate(drv)`` finds and press Enter (re-finding it if
    Dash re-rendered it meanwhile)."""
    for attempt in range(3):
        try:
            el = locate(drv)
            el.click()
            el.send_keys(Keys.CONTROL, "a")
            el.send_keys(Keys.DELETE)
            el.send_keys(text, Keys.ENTER)
            return
        except StaleElementReferenceException:
            if attempt == 2:
                raise
            time.sleep(0.3)


def by_id(id_: str):
    return lambda d: d.find_element(By.ID, id_)


def tab(drv, label: str, wait: float = 30.0) -> None:
    """Click the tab named ``label``, waiting (up to ``wait`` s) for the page to render it."""
    deadline = time.monotonic() + wait
    while True:
        try:
            for el in drv.find_elements(By.CSS_SELECTOR, ".tab"):
                if el.text.strip() == label:
                    el.click()
                    return
        except StaleElementReferenceException:  # re-rendered while we looked: look again
            pass
        if time.monotonic() > deadline:
            raise AssertionError(f"no tab {label!r} after {wait:.0f} s")
        time.sleep(0.2)
