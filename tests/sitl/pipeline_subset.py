"""A repository pipeline cut to the cases a test module reads, flown on a world the session built once.

The firmware tests' batches are minutes of real-firmware flight each; a case no test reads is flight for
nothing, and building the pipeline's world again per batch repeats what ``sample_world_dir`` built.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from tests.repo_paths import REPO


def pipeline_subset(name: str, stems: tuple[str, ...], world: Path, folder: Path) -> Path:
    """``pipelines/<name>.yaml`` with only its missions whose file stems are ``stems`` (in the pipeline's order),
    flown on the built ``world``, written into ``folder``; its path."""
    doc = yaml.safe_load((REPO / "pipelines" / f"{name}.yaml").read_text())
    doc["missions"] = [str(REPO / "pipelines" / m) for m in doc["missions"] if Path(m).stem in stems]
    if len(doc["missions"]) != len(stems):
        raise ValueError(f"pipelines/{name}.yaml: not one mission each for {stems}")
    doc["world"] = str(world)
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path
