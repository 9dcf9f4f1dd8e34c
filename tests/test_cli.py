"""`dd-contact verify`: table, JSON records, exit status."""

import json

import pytest

from dd_contact import cli, verify

FIELDS = {"case", "quantity", "value", "reference", "rel_error", "tolerance", "passed"}


def test_verify_one_case_writes_json(tmp_path, capsys):
    path = tmp_path / "v.json"
    assert cli.main(["verify", "--case", "patch-hex-quad", "--json", str(path)]) == 0
    records = json.loads(path.read_text())
    assert len(records) == 1
    assert set(records[0]) == FIELDS
    assert records[0]["passed"] is True
    assert records[0]["rel_error"] < 1e-6
    assert "patch-hex-quad" in capsys.readouterr().out


def test_verify_exits_1_when_a_case_fails(monkeypatch):
    failing = verify.Record("broken", "x", 2.0, 1.0, 1.0, 1e-3, False)
    monkeypatch.setitem(verify.CASES, "broken", lambda: [failing])
    assert cli.main(["verify", "--case", "broken"]) == 1


def test_verify_unknown_case():
    with pytest.raises(ValueError, match=r"unknown case.*valid: patch-hex-quad"):
        cli.main(["verify", "--case", "nope"])
