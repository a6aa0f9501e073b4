"""The wheel's contents: every package of the tree is listed, the models ship inside the package."""

import tomllib
from pathlib import Path

from tsad_drake.station_models import PACKAGE_XML, models_dir

ROOT = Path(__file__).resolve().parent.parent


def test_every_package_of_the_tree_is_in_the_wheel_list():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    listed = set(config["packages"])
    on_disk = {".".join(p.parent.relative_to(ROOT).parts)
               for p in (ROOT / "tsad_drake").rglob("*.py") if "__pycache__" not in p.parts}
    assert on_disk - listed == set(), "add these packages to pyproject.toml"
    assert listed - on_disk == {"tsad_drake.models"}
    assert config["package-dir"] == {"tsad_drake.models": "models"}
    for pattern in config["package-data"]["tsad_drake.models"]:
        assert list((ROOT / "models").glob(pattern)), pattern


def test_models_are_found_in_the_checkout():
    assert models_dir() == ROOT / "models" and PACKAGE_XML.is_file()
    assert (models_dir() / "urdf" / "ur5e" / "ur5e.urdf").is_file()
