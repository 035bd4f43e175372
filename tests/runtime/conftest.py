import shutil
from pathlib import Path

import pytest

MODELS = Path(__file__).parents[2] / "models"


@pytest.fixture
def certified(tmp_path):
    """A function: a controller configuration as parameters the runtime accepts.

    This build's certificate check is the interim one (``runtime.params``): a
    certificate.json beside the file. Once issue 14's check is merged, this fixture must
    make a real export instead (verify + export, as tests/verification's ``exported``)."""
    def make(config: str = "iso.yaml") -> Path:
        folder = tmp_path / f"params_{Path(config).stem}"
        folder.mkdir()
        shutil.copy(MODELS / "configs" / config, folder / "params.yaml")
        (folder / "certificate.json").write_text("{}\n")
        return folder / "params.yaml"

    return make
