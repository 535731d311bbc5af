"""Packaging: every shipped data file is package data, the licence and version are declared once."""

from __future__ import annotations

import fnmatch
import sys
from pathlib import Path

import tinyrace
from tinyrace.examples import DATA_DIR

if sys.version_info >= (3, 11):
    import tomllib
else:  # the test extra installs tomli on Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = Path(tinyrace.__file__).resolve().parent


def pyproject() -> dict:
    with (ROOT / "pyproject.toml").open("rb") as file:
        return tomllib.load(file)


def test_every_data_file_is_package_data():
    patterns = pyproject()["tool"]["setuptools"]["package-data"]["tinyrace"]
    files = [p.relative_to(PACKAGE).as_posix() for p in DATA_DIR.rglob("*") if p.is_file()]
    files = [f for f in files if "__pycache__" not in f]
    left_out = [f for f in files if not any(fnmatch.fnmatch(f, p) for p in patterns)]
    assert files and not left_out, f"add to [tool.setuptools.package-data]: {left_out}"


def test_licence_is_an_spdx_expression_with_its_file():
    project = pyproject()["project"]
    assert project["license"] == "MIT"
    assert project["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert not any("License ::" in c for c in project.get("classifiers", []))


def test_version_is_declared_once():
    version = pyproject()["project"]["version"]
    assert tinyrace.__version__ == version
    sources = [p for p in PACKAGE.rglob("*.py") if f'"{version}"' in p.read_text()]
    assert sources == [], "the version is read from the package metadata, not written twice"


def test_the_train_example_is_outside_the_main_test_run():
    config = pyproject()
    assert config["tool"]["pytest"]["ini_options"]["testpaths"] == ["tests"]
    assert "stable-baselines3" not in " ".join(config["project"]["optional-dependencies"]["test"])


def test_a_plain_install_takes_the_compiled_path():
    project = pyproject()["project"]
    assert any(d.replace(" ", "").startswith("numba>=") for d in project["dependencies"])
    assert project["optional-dependencies"]["fast"] == []  # an alias kept for old commands
    test_extra = " ".join(project["optional-dependencies"]["test"])
    assert "pytest-xdist" in test_extra  # the README's test command runs on every core


def test_the_readme_is_the_package_description_and_names_no_checkout_file_to_run():
    project = pyproject()["project"]
    assert project["readme"] == "README.md"
    readme = (ROOT / "README.md").read_text()
    assert "tinyrace/data/" not in readme and "[fast]" not in readme
