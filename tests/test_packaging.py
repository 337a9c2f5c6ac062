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


def test_version_is_the_installed_metadata_and_agrees_with_pyproject():
    from importlib.metadata import version

    import discgym

    assert discgym.__version__ == version("discgym") == PROJECT["project"]["version"]


def test_version_without_metadata_falls_back_to_the_tree_s_pyproject(monkeypatch, tmp_path):
    import importlib.metadata

    import discgym

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", missing)
    assert discgym._find_version() == PROJECT["project"]["version"]  # this source tree
    (tmp_path / "discgym").mkdir()
    monkeypatch.setattr(discgym, "__file__", str(tmp_path / "discgym" / "__init__.py"))
    assert discgym._find_version() == "0+unknown"  # no pyproject.toml beside the package
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "other"\nversion = "9.9"\n')
    assert discgym._find_version() == "0+unknown"  # another project's
    (tmp_path / "pyproject.toml").write_text('[project]\nname = "discgym"\nversion = "9.9"\n')
    assert discgym._find_version() == "9.9"
    (tmp_path / "pyproject.toml").write_text("[project\n")
    assert discgym._find_version() == "0+unknown"  # malformed


def test_build_backend_understands_the_spdx_license_and_no_classifier_contradicts_it():
    # setuptools 77 is the first to read `license = "<SPDX>"` with `license-files` (PEP 639);
    # from then on it refuses a License :: classifier beside the expression
    requires = PROJECT["build-system"]["requires"]
    setuptools = [r for r in requires if re.match(r"setuptools\b", r)]
    assert len(setuptools) == 1
    floor = re.fullmatch(r"setuptools\s*>=\s*(\d+)(\.\d+)*", setuptools[0])
    assert floor and int(floor.group(1)) >= 77, setuptools
    classifiers = PROJECT["project"]["classifiers"]
    assert not [c for c in classifiers if c.startswith("License ::")]
    assert "Operating System :: OS Independent" in classifiers
    # the Python versions named are all ones requires-python admits
    low = re.fullmatch(r">=\s*3\.(\d+)", PROJECT["project"]["requires-python"]).group(1)
    minors = [int(c.rsplit(".", 1)[1]) for c in classifiers
              if re.fullmatch(r"Programming Language :: Python :: 3\.\d+", c)]
    assert minors and min(minors) == int(low)
    assert PROJECT["project"]["keywords"]


def test_project_urls_name_the_repository_its_docs_changelog_and_issues():
    urls = PROJECT["project"]["urls"]
    repo = "https://github.com/discgym/discgym"
    assert urls["Homepage"] == urls["Repository"] == repo
    assert urls["Documentation"] == f"{repo}/tree/main/docs"
    assert urls["Changelog"] == f"{repo}/blob/main/CHANGELOG.md"
    assert urls["Issues"] == f"{repo}/issues"
    cff = (ROOT / "CITATION.cff").read_text()
    assert re.search(rf'^repository-code: "{repo}"$', cff, re.M)


def test_every_scene_file_and_subpackage_is_in_the_distribution():
    import fnmatch

    data = PROJECT["tool"]["setuptools"]["package-data"]
    scenes = sorted((ROOT / "discgym" / "scenes").glob("*.toml"))
    assert scenes and all(any(fnmatch.fnmatch(p.name, g) for g in data["discgym.scenes"])
                          for p in scenes)
    include = PROJECT["tool"]["setuptools"]["packages"]["find"]["include"]
    for init in (ROOT / "discgym").rglob("__init__.py"):
        name = ".".join(init.parent.relative_to(ROOT).parts)
        assert any(fnmatch.fnmatch(name, g) for g in include), name


def test_readme_links_are_absolute_for_the_package_index():
    # the README is the package index's page, where a path relative to the repository leads
    # nowhere and an image under it does not show
    readme = (ROOT / PROJECT["project"]["readme"]).read_text()
    targets = re.findall(r"\]\(\s*<?([^)\s>]+)", readme)
    targets += re.findall(r"""(?:src|href)\s*=\s*["']([^"']+)""", readme)
    targets += re.findall(r"^\s*\[[^\]]+\]:\s*(\S+)", readme, re.M)  # reference definitions
    assert targets
    relative = [t for t in targets if not re.match(r"(https?://|mailto:|#)", t)]
    assert relative == []


def test_ci_tests_the_lowest_versions_pyproject_allows():
    """CI's second run (.ci/run) installs .ci/lowest.txt: each pin there is the lower bound
    of that dependency in pyproject.toml, and every dependency with a lower bound is pinned,
    so the declared range is the tested range at both ends."""
    bounds = {}
    for dep in PROJECT["project"]["dependencies"]:
        m = re.fullmatch(r"([A-Za-z0-9_.-]+)\s*>=\s*([0-9][0-9.]*)", dep)
        assert m, f"{dep}: a dependency of pyproject.toml without a plain lower bound"
        bounds[m.group(1).lower()] = m.group(2)
    pins = {}
    for line in (ROOT / ".ci" / "lowest.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            m = re.fullmatch(r"([A-Za-z0-9_.-]+)==([0-9][0-9.]*)", line)
            assert m, f".ci/lowest.txt: {line!r} is not name==version"
            pins[m.group(1).lower()] = m.group(2)
    assert pins == bounds
    assert "lowest.txt" in (ROOT / ".ci" / "run").read_text()
