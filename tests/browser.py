"""Headless Debian Chromium through selenium, for the tests that look at a page as a user does."""

from __future__ import annotations

import shutil
from typing import Any

import pytest


def chromium(width: int = 1400, height: int = 900) -> Any:
    """A selenium driver of headless Chromium with a ``width`` × ``height`` window (a laptop screen by default);
    the test is skipped where Debian's ``chromium`` and ``chromium-driver`` are not installed."""
    binary, driver = shutil.which("chromium") or shutil.which("chromium-browser"), shutil.which("chromedriver")
    if binary is None or driver is None:
        pytest.skip(
            "Debian chromium and chromium-driver are not installed (scripts/setup.sh --test installs them as root)"
        )
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    for argument in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        f"--window-size={width},{height}",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
    ):
        options.add_argument(argument)
    options.binary_location = binary
    return webdriver.Chrome(options=options, service=Service(driver))
