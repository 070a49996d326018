"""``conformorph morph`` builds the MT baseline only with ``--baselines``; the GLB and
every other figure are the same either way, and metrics.json says what it left out."""

import json

from conformorph.cli.main import main
from conformorph.pipelines.face_morph import FaceMorphOptions, FrameOptions, RegistrationOptions
from conformorph.pipelines.face_morph.run import skipped_measures
from tests.cli.test_cmd_morph import _inputs


def _untimed(x):
    """``x`` without any timing (every key naming seconds, at any depth)."""
    if isinstance(x, dict):
        return {k: _untimed(v) for k, v in x.items() if "seconds" not in k}
    if isinstance(x, list):
        return [_untimed(v) for v in x]
    return x


def _without(m: dict, *keys: str) -> dict:
    m = _untimed(m)
    for k in keys:
        m.pop(k, None)
    m["registration"]["composite_folded_triangles"].pop("mt", None)
    m["registration"]["composite_min_jacobian"].pop("mt", None)
    m["registration"]["variants"] = ["main"]
    m["frames"]["key_frame_L2_to_inputs"].pop("mt", None)
    m["frames"].get("key_frame_L2_bound", {}).pop("mt", None)
    for i in m["inputs"]:  # the key cache: the first run stores, the second finds
        i.pop("cache", None)
    return m


def test_default_skips_the_mt_baseline_and_says_so(tmp_path, capsys):
    paths, L = _inputs(tmp_path)
    runs = {}
    for name, extra in (("default", []), ("baselines", ["--baselines"])):
        out = tmp_path / name
        assert (
            main(
                ["morph", *paths, "--landmarks", L, "--frames", "4", "-o", str(out)]
                + extra
                + ["--json", "-q"]
            )
            == 0
        )
        runs[name] = json.loads(capsys.readouterr().out)
        assert json.loads((out / "metrics.json").read_text()) == runs[name]
    d, b = runs["default"], runs["baselines"]
    assert set(d["frames"]["key_frame_L2_to_inputs"]) == {"dmt", "linear"}
    assert set(b["frames"]["key_frame_L2_to_inputs"]) == {"dmt", "mt", "linear"}
    assert d["registration"]["variants"] == ["main"]
    assert b["registration"]["variants"] == ["main", "mt"]
    assert "--baselines" in d["skipped"]["mt_baseline"] and b["skipped"] == {}
    # the MT pair registration itself always runs (it places every key disk)
    assert d["registration"]["pairs"][0]["E_D"]["mt"] == b["registration"]["pairs"][0]["E_D"]["mt"]
    assert _without(d, "skipped") == _without(b, "skipped")
    glb = [(tmp_path / n / "animation.glb").read_bytes() for n in ("default", "baselines")]
    assert glb[0] == glb[1]


def test_skipped_measures_names_each_left_out_measure():
    full = FaceMorphOptions()
    assert skipped_measures(full, measured=True) == {}
    assert set(skipped_measures(full, measured=False)) == {"mt_baseline"}
    lean = FaceMorphOptions(
        registration=RegistrationOptions(baselines=False),
        homotopy=FrameOptions(key_metrics=False),
    )
    assert set(skipped_measures(lean, measured=False)) == {"key_frame_metrics", "mt_baseline"}
    mt = FaceMorphOptions(registration=RegistrationOptions(method="mt", baselines=False))
    assert skipped_measures(mt, measured=True) == {}


def test_one_baselines_default_for_the_cli_the_api_and_the_worker() -> None:
    """``--baselines`` / the job field ``baselines`` share job_fields' default (off):
    before, a job always built the MT baseline that the CLI builds only on request."""
    from conformorph.cli.main import build_parser
    from conformorph.pipelines.job_fields import MORPH_BASELINES_DEFAULT
    from conformorph.service.schemas import MorphCreate
    from conformorph.worker.stages.face_morph import morph_options_from_params

    assert MORPH_BASELINES_DEFAULT is False
    base = ["morph", "a.obj", "b.obj", "--landmarks", "l.json", "-o", "o"]
    assert build_parser().parse_args(base).baselines is False
    assert build_parser().parse_args([*base, "--baselines"]).baselines is True
    assert MorphCreate(meshes=["a" * 32, "b" * 32]).baselines is False
    assert morph_options_from_params({}).registration.baselines is False
    assert morph_options_from_params({"baselines": True}).registration.baselines is True
