"""The splat package: cheap import, lazy public names, errors in the project hierarchy."""

from __future__ import annotations

import subprocess
import sys

import splat
import zonotope


def test_import_splat_does_not_import_jax():
    code = "import sys, splat; print('jax' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_public_names_resolve_and_errors_subclass_the_project_ones():
    for name in splat.__all__:
        assert getattr(splat, name) is not None
    assert issubclass(splat.SplatError, zonotope.ZonotopeError)
    assert issubclass(splat.SplatError, ValueError)
    assert issubclass(splat.DataFormatError, splat.SplatError)
    assert callable(splat.render) and callable(splat.train)


def test_moved_modules_import_as_their_new_module_with_a_deprecation_warning():
    code = (
        "import warnings, importlib, splat\n"
        "for old, new in splat._MOVED_MODULES.items():\n"
        "    with warnings.catch_warnings(record=True) as w:\n"
        "        warnings.simplefilter('always')\n"
        "        m = importlib.import_module(old)\n"
        "    assert m is importlib.import_module(new), old\n"
        "    assert m.__spec__.name == new and m.__name__ == new, old\n"
        "    dep = [x for x in w if issubclass(x.category, DeprecationWarning)]\n"
        "    assert any(new in str(x.message) for x in dep), old\n"
        "from splat.simcapture import write_synthetic_capture\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr


#: Public names of the former ``splat.pipeline`` and ``splat.workspace`` modules (now ``splat.capture``).
OLD_PIPELINE = (
    "PipelineConfig STEPS TrainingInputs XYZ_to_sRGB check_run choose_delta correct_fused correct_step "
    "correction_problem_of delta_of depth_targets dng_matrix_XYZ fit_corrector fit_fused_corrector fit_step "
    "fused_fitter pipeline_mix fused_view fusion_of load_gaussians noise_sigma own_noise photographed_view "
    "pose_corrections_of poses_step preview_binning preview_upscale read_index refined_views render_step "
    "report_step reprojected_of run train_config train_size_of training_inputs views_to_render white_of "
    "working_binning working_summary working_views"
).split()
OLD_WORKSPACE = (
    "MARKER SETTINGS STEP_OUTPUTS Workspace capture_fingerprint peak_rss_mib read_json reset_peak_rss"
)


def test_old_pipeline_and_workspace_names_import_from_the_old_and_the_new_paths():
    code = (
        "import importlib, warnings\n"
        "import splat.capture as new\n"
        "import splat.capture.workspace as new_ws\n"
        f"for old, names, where in [('splat.pipeline', {OLD_PIPELINE!r}, new),\n"
        f"                          ('splat.workspace', {OLD_WORKSPACE.split()!r}, new_ws)]:\n"
        "    with warnings.catch_warnings(record=True) as w:\n"
        "        warnings.simplefilter('always')\n"
        "        m = importlib.import_module(old)\n"
        "    assert any(issubclass(x.category, DeprecationWarning) for x in w), old\n"
        "    for n in names:\n"
        "        assert getattr(m, n) is getattr(where, n) is getattr(new, n), (old, n)\n"
        "from splat.pipeline import run, PipelineConfig\n"
        "from splat.workspace import Workspace\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr


def test_capture_modules_import_no_private_name_from_each_other():
    import ast
    from pathlib import Path

    import splat.capture

    crossing = []
    for path in Path(splat.capture.__file__).parent.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                crossing += [f"{path.name}: {a.name}" for a in node.names if a.name.startswith("_")]
    assert crossing == []
