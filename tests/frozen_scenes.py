"""Generated scenes frozen as JSON (tests/planning/scenes/), so generator changes do not move the
tests that plan on them. Imported as a top-level module: tests/ is on sys.path (tests/conftest.py)."""

import json
from pathlib import Path

from tsad_drake.scenario import GridConfig, GripperConfig, ObjectConfig, Scenario, ShelfConfig

SCENES = Path(__file__).parent / "planning" / "scenes"


def load_scene(name: str, seed: int) -> Scenario:
    """The frozen copy of generate_scenario(name, seed) of the generator before the shared clearance
    (the JSON records the planning clearance of 0 they were generated and are planned with)."""
    data = json.loads((SCENES / f"scene_{name}_{seed}.json").read_text())
    return Scenario(**{**data, "shelf": ShelfConfig(**data["shelf"]), "grid": GridConfig(**data["grid"]),
                       "gripper": GripperConfig(**data["gripper"]),
                       "objects": [ObjectConfig(**o) for o in data["objects"]]})
