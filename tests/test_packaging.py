"""The distribution's metadata files agree with pyproject.toml."""

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_license_file_matches_pyproject():
    assert PROJECT["project"]["license"] == "MIT"
    assert PROJECT["project"]["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")


def test_package_is_marked_typed_and_ships_the_marker():
    assert (ROOT / "discgym" / "py.typed").is_file()
    assert "py.typed" in PROJECT["tool"]["setuptools"]["package-data"]["discgym"]


def test_citation_names_this_version_and_license():
    cff = (ROOT / "CITATION.cff").read_text()
    assert re.search(r"^cff-version: 1\.2\.0$", cff, re.M)
    version = re.search(r'^version: "(.+)"$', cff, re.M).group(1)
    assert version == PROJECT["project"]["version"]
    assert re.search(r"^license: MIT$", cff, re.M)
