"""`dd-contact verify`: table, JSON records, exit status."""

import importlib.metadata
import json
import re
from pathlib import Path

import pytest

import dd_contact
from dd_contact import calibration, cli, timing
from dd_contact.paper import flops, verify

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


def _nothing_runs(*args, **kwargs):
    raise AssertionError("a case ran although the arguments were wrong")


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--case", "nonsense"], "unknown case 'nonsense'; valid: patch-hex-quad, "),
        (["--json", "/no/such/dir/x.json"], "directory /no/such/dir does not exist"),
    ],
)
def test_verify_usage_errors_exit_2_before_running(monkeypatch, capsys, argv, message):
    monkeypatch.setattr(cli, "run_cases", _nothing_runs)
    assert cli.main(["verify", *argv]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith("dd-contact verify: error: ") and message in captured.err
    assert captured.err.count("\n") == 1  # one line, no traceback


def test_version(capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"dd-contact {importlib.metadata.version('dd-contact')}\n"
    assert dd_contact.__version__ == importlib.metadata.version("dd-contact")


@pytest.mark.parametrize(
    "command",
    [[], ["verify"], ["flops"], ["flops", "parallelepiped"], ["flops", "pin-joint"], ["calibrate"]],
)
def test_help_has_no_rest_markup(capsys, command):
    with pytest.raises(SystemExit) as exc:
        cli.main([*command, "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: dd-contact")
    assert "``" not in out and re.search(r":\w+:`", out) is None
    if not command:
        assert "dd-contact verify: run the verification cases" in out


def test_calibrate_shows_progress_on_stderr(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("DD_CONTACT_CACHE", str(tmp_path))
    rates = timing.MachineRates({kind: [[1e6, 1e-3]] for kind in timing.RATE_KINDS}, {})

    def measure(quick, progress):
        for done in range(1, 5):
            progress(done, 4)
        return rates

    monkeypatch.setattr(calibration, "calibrate", measure)
    assert cli.main(["calibrate", "--quick"]) == 0
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert lines[0] == "dd-contact calibrate: measuring this machine's rates (about 3 s)"
    assert "4/4" in captured.err  # the progress bar reached the end
    assert "sparse_factor" in captured.out


# --------------------------------------------------------------------------- dd-contact flops

MESH_KEYS = {
    "name",
    "dofs",
    "half_bandwidth",
    "decompositions",
    "substitutions",
    "gflops_decomposition",
    "gflops_substitution",
}
DOCS = Path(__file__).resolve().parents[1] / "docs"


def api_json(sizes) -> dict:
    return json.loads(json.dumps(flops.to_json_dict(flops.compare(sizes))))


def test_flops_parallelepiped_defaults_json(tmp_path, capsys):
    path = tmp_path / "bar.json"
    assert cli.main(["flops", "parallelepiped", "--json", str(path)]) == 0
    data = json.loads(path.read_text())
    assert list(data) == ["FULL", "v-w-u", "w-v-u", "w-u", "v-u"]
    for alg in data.values():
        assert set(alg) == {"gflops_total", "percent_of_full", "meshes"}
        assert all(set(m) == MESH_KEYS for m in alg["meshes"])
    assert data == api_json(flops.parallelepiped_sizes())
    # the paper's bar: counts by hand
    full = data["FULL"]["meshes"][0]
    assert (full["dofs"], full["half_bandwidth"], full["decompositions"]) == (1336533, 3372, 20001)
    assert full["substitutions"] == 30000
    assert [m["name"] for m in data["v-w-u"]["meshes"]] == [
        "Omega1",
        "Omega2",
        "Gamma_C1",
        "Gamma_I",
    ]
    assert data["v-w-u"]["meshes"][2]["substitutions"] == 20001 * 3333 + 30000 + 30000
    pct = {a: round(v["percent_of_full"], 4) for a, v in data.items()}
    # one subdomain substitution per step: the paper's Table 3 (0.600, 0.153, 0.146 %)
    assert pct == {"FULL": 100.0, "v-w-u": 0.6005, "w-v-u": 0.1534, "w-u": 0.1457, "v-u": 198.8409}
    out = capsys.readouterr().out
    assert "1,336,533 dofs, B = 3,372" in out and "(0.6005 % of FULL)" in out

    # explicit paper arguments, and --json given before the model name, give the same file
    explicit = tmp_path / "explicit.json"
    argv = ["flops", "--json", str(explicit), "parallelepiped", "--elements", "400", "100", "10"]
    argv += ["--split", "5:5", "--interface", "100", "10", "--contact", "100", "10"]
    assert cli.main([*argv, "--steps", "10000", "--changes", "20000"]) == 0
    assert json.loads(explicit.read_text()) == data


def test_flops_parallelepiped_options(tmp_path):
    path = tmp_path / "bar.json"
    argv = ["flops", "parallelepiped", "--elements", "40", "10", "2", "--split", "1:3"]
    argv += ["--interface", "5", "1", "--contact", "10", "2", "--steps", "7", "--changes", "9"]
    assert cli.main([*argv, "--json", str(path)]) == 0
    sizes = flops.parallelepiped_sizes((40, 10, 2), (1, 3), (5, 1), (10, 2), 7, 9)
    assert json.loads(path.read_text()) == api_json(sizes)
    assert sizes.subdomains[0].dofs == 11 * 11 * 3 * 3 and sizes.interface_dofs == 6 * 2 * 3
    with pytest.raises(SystemExit) as exc:
        cli.main(["flops", "parallelepiped", "--split", "5-5"])
    assert exc.value.code == 2
    # a split that does not divide the layers is a clean error, not a traceback
    assert cli.main(["flops", "parallelepiped", "--split", "1:6"]) == 2


def test_flops_pin_joint(tmp_path, capsys):
    path = tmp_path / "pin.json"
    assert cli.main(["flops", "pin-joint", "--active-holes", "2", "--json", str(path)]) == 0
    data = json.loads(path.read_text())
    assert data == api_json(flops.pin_joint_sizes(2))
    assert len(data["v-w-u"]["meshes"]) == 12 + 2 + 1
    assert data["w-v-u"]["percent_of_full"] < data["v-w-u"]["percent_of_full"]
    out = capsys.readouterr().out
    assert "174,080 hexahedra, 201,672 nodes, 605,016 dofs" in out
    assert "2 of 10 holes in contact" in out
    assert cli.main(["flops", "pin-joint", "--active-holes", "11"]) == 2
    assert "active_holes must be in 1..10" in capsys.readouterr().err


def test_flops_scene_example_matches_parallelepiped(tmp_path):
    path = tmp_path / "scene.json"
    assert (
        cli.main(["flops", "--scene", str(DOCS / "scene_example.json"), "--json", str(path)]) == 0
    )
    assert json.loads(path.read_text()) == api_json(flops.parallelepiped_sizes())


SCENE = {
    "n_steps": 3,
    "gamma": 2,
    "interface": {"dofs": 6},
    "subdomains": [
        {"name": "Omega1", "dofs": 30, "half_bandwidth": 9},
        {"name": "Omega2", "dofs": 30, "half_bandwidth": 9},
    ],
    "contacts": [{"dofs": 6, "subdomain": "Omega1", "alpha": 2}],
}


@pytest.mark.parametrize(
    "edit,message",
    [
        (lambda d: d.pop("n_steps"), "missing key 'n_steps'"),
        (lambda d: d["subdomains"][0].pop("half_bandwidth"), "subdomains[0]: missing key"),
        (lambda d: d["subdomains"][1].update(dofs=-30), "subdomains[1].dofs must be a positive"),
        (lambda d: d["contacts"][0].update(alpha=-1), "contacts[0].alpha must be a non-negative"),
        (lambda d: d["contacts"][0].update(subdomain="Omega9"), "'Omega9' is not a subdomain"),
        (lambda d: d["contacts"][0].update(subdomain=5), "index 5 is not a subdomain"),
    ],
)
def test_flops_scene_validation_errors(tmp_path, capsys, edit, message):
    data = json.loads(json.dumps(SCENE))
    edit(data)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(data))
    assert cli.main(["flops", "--scene", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"dd-contact flops: error: {path}: ")
    assert message in err


def test_flops_scene_ok_and_usage_errors(tmp_path, capsys):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(SCENE))
    out_json = tmp_path / "out.json"
    assert cli.main(["flops", "--scene", str(path), "--json", str(out_json)]) == 0
    # no "whole": summed dofs and largest bandwidth; v-w-u as in test_flops.test_tiny_vwu_table1
    # with one subdomain substitution per step (2 x 3 f4(30, 9) = 4860 fewer than Table 1's)
    data = json.loads(out_json.read_text())
    assert data["FULL"]["meshes"][0]["dofs"] == 60
    assert data["v-w-u"]["gflops_total"] == pytest.approx((30402 - 4860) * 1e-9, rel=1e-12)
    assert cli.main(["flops"]) == 2
    assert "give a model" in capsys.readouterr().err
    assert cli.main(["flops", "--scene", str(path), "parallelepiped"]) == 2
    assert "exclude each other" in capsys.readouterr().err
    assert cli.main(["flops", "--scene", str(tmp_path / "missing.json")]) == 2
    assert "missing.json" in capsys.readouterr().err


def is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and path.stat().st_size > 10_000


def test_flops_sweep_writes_charts(tmp_path):
    measured = tmp_path / "measured.json"
    measured.write_text(json.dumps({"bar_steps": {"w-u": [[100, 3.0]]}}))
    out = tmp_path / "charts"
    argv = ["flops", "parallelepiped", "--sweep", str(out), "--measured", str(measured)]
    assert cli.main(argv) == 0
    names = ["bar_steps", "bar_split", "bar_changes", "bar_contact_elements"]
    for name in names:
        assert is_png(out / f"flops_{name}.png")
        assert json.loads((out / f"flops_{name}.json").read_text())["name"] == name
    steps = json.loads((out / "flops_bar_steps.json").read_text())
    assert steps["measured"] == {"w-u": [[100, 3.0]]}
    bar = flops.compare(flops.parallelepiped_sizes())
    assert steps["percent_of_full"]["v-w-u"][-1] == pytest.approx(bar["v-w-u"].percent_of_full)

    assert cli.main(["flops", "pin-joint", "--sweep", str(out)]) == 0
    holes = json.loads((out / "flops_pin_holes.json").read_text())
    assert holes["x"] == list(range(2, 11))
    assert is_png(out / "flops_pin_holes.png") and is_png(out / "flops_pin_steps.png")

    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps(SCENE))
    assert cli.main(["flops", "--scene", str(scene), "--sweep", str(out)]) == 0
    assert is_png(out / "flops_scene_steps.png") and is_png(out / "flops_scene_changes.png")
