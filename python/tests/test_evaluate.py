"""kestrel.evaluate() gives what `kestrel evaluate` prints, from files or Trajectory objects."""

import subprocess

import pytest

import kestrel


def test_evaluate_equals_cli(reference_trajectories, kestrel_binary):
    gt = reference_trajectories / "freiburg1_xyz-groundtruth.txt"
    est = reference_trajectories / "freiburg1_xyz-rgbdslam.txt"
    cli = subprocess.run([str(kestrel_binary), "evaluate", "--gt", str(gt), "--est", str(est)],
                         check=True, capture_output=True, text=True).stdout
    cli_summary = [line for line in cli.splitlines() if line.startswith("ate_rmse_m=")]

    evaluation = kestrel.evaluate(gt, est)
    assert cli_summary == [evaluation.summary_line()]
    fields = dict(item.split("=") for item in evaluation.summary_line().split())
    assert float(fields["ate_rmse_m"]) == pytest.approx(evaluation.ate_rmse_m, rel=1e-5)
    assert float(fields["rpe_trans_m_s"]) == pytest.approx(evaluation.rpe_trans_m_s, rel=1e-5)
    assert float(fields["rpe_rot_deg_s"]) == pytest.approx(evaluation.rpe_rot_deg_s, rel=1e-5)
    assert evaluation.pairs > 100 and evaluation.ate_rmse_m > 0

    from_objects = kestrel.evaluate(kestrel.read_trajectory(gt), kestrel.read_trajectory(est))
    assert from_objects.summary_line() == evaluation.summary_line()
    assert from_objects.ate_rmse_m == evaluation.ate_rmse_m


def test_evaluate_reports_bad_input(tmp_path):
    bad = tmp_path / "bad.txt"
    bad.write_text("1.0 0 0 0 0 0 0\n")
    with pytest.raises(kestrel.InputError, match=r"bad.txt:1"):
        kestrel.evaluate(bad, bad)
    with pytest.raises(ValueError):  # InputError is a ValueError
        kestrel.evaluate(bad, bad)
