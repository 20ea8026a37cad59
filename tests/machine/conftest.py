import pytest


@pytest.fixture(autouse=True)
def _config_dir(tmp_path, monkeypatch):
    # never read or write the developer's own remembered port settings
    monkeypatch.setenv("LABKIT_CONFIG_DIR", str(tmp_path / "config"))
