"""Packaging: the code's packages are all listed, the shipped examples' one copy (the
repository's top-level example_tracks/ and configs/) is mapped into the package with every
file as package data, the licence and version are declared once."""

from __future__ import annotations

import fnmatch
import sys
from pathlib import Path

import tinyrace
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR

if sys.version_info >= (3, 11):
    import tomllib
else:  # the test extra installs tomli on Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = Path(tinyrace.__file__).resolve().parent  # imported: a checkout's or a wheel's
SOURCE = ROOT / "tinyrace"  # the package's source


def pyproject() -> dict:
    with (ROOT / "pyproject.toml").open("rb") as file:
        return tomllib.load(file)


# The shipped examples: package -> its folder at the top of the repository.
DATA_PACKAGES = {"tinyrace.example_tracks": "example_tracks", "tinyrace.configs": "configs"}


def test_every_code_package_is_listed():
    code = sorted(".".join(p.parent.relative_to(ROOT).parts) for p in SOURCE.rglob("__init__.py"))
    listed = pyproject()["tool"]["setuptools"]["packages"]
    missing = sorted(set(code) - set(listed))
    assert not missing, f"add to [tool.setuptools] packages in pyproject.toml: {missing}"
    assert sorted(listed) == sorted([*code, *DATA_PACKAGES])


def test_the_examples_are_top_level_folders_mapped_into_the_package():
    setuptools = pyproject()["tool"]["setuptools"]
    assert setuptools["package-dir"] == DATA_PACKAGES
    for folder in DATA_PACKAGES.values():
        assert (ROOT / folder).is_dir() and not (SOURCE / folder).exists(), folder
    # tinyrace.examples finds them beside a checkout's package, inside an installed wheel's
    home = ROOT if PACKAGE == SOURCE else PACKAGE
    assert (home / "example_tracks", home / "configs") == (TRACKS_DIR, CONFIGS_DIR)


def test_every_example_file_is_package_data():
    package_data = pyproject()["tool"]["setuptools"]["package-data"]
    files, left_out = [], []
    for package, folder in DATA_PACKAGES.items():
        for path in (ROOT / folder).rglob("*"):
            name = path.relative_to(ROOT / folder).as_posix()
            if not path.is_file() or "__pycache__" in name:
                continue
            files.append(f"{folder}/{name}")
            is_module = "/" not in name and name.endswith(".py")  # a module of the package
            if not is_module and not any(fnmatch.fnmatch(name, p) for p in package_data[package]):
                left_out.append(files[-1])
    assert files and not left_out, f"add to [tool.setuptools.package-data]: {left_out}"


def test_the_package_holds_no_data_file_left_out_of_the_wheel():
    patterns = pyproject()["tool"]["setuptools"]["package-data"]["tinyrace"]
    files = [p.relative_to(SOURCE).as_posix() for p in SOURCE.rglob("*") if p.is_file()]
    files = [f for f in files if "__pycache__" not in f and not f.endswith(".py")]
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
