"""numba's and pydrake's warnings go to DIR/third_party.log, not to the console; the
project's own warnings still reach it, one line each."""

import logging
import signal
import warnings

from numba.core.errors import NumbaIRAssumptionWarning, NumbaPerformanceWarning

from safety_systems import cli, third_party_noise
from safety_systems.third_party_noise import LOG_NAME, is_noise, kept_in

PEDANTIC = ("variable 'chain_v290' is not in scope. This warning came from an internal "
            "pedantic check. Please report the following to github.com/numba/numba")


def test_numbas_and_pydrakes_warnings_are_noise_the_projects_are_not():
    assert is_noise(NumbaIRAssumptionWarning, "/x/numba/core/ir.py")
    assert is_noise(NumbaPerformanceWarning, "/x/safety_systems/cell/chain_kinematics.py")
    assert is_noise(UserWarning, "/x/site-packages/pydrake/multibody/parsing.py")
    assert not is_noise(UserWarning, "/x/safety_systems/sensing/motive_csv.py")
    assert not is_noise(RuntimeWarning, "/x/numpy/core/fromnumeric.py")


def test_noise_is_kept_in_the_log_once_its_folder_exists(tmp_path):
    shown = []
    folder = tmp_path / "out"
    with kept_in(folder / LOG_NAME, lambda *a: shown.append(str(a[0]))):
        warnings.warn(NumbaIRAssumptionWarning(PEDANTIC))
        logging.getLogger("drake").warning("Meshcat listening")
        warnings.warn("a truncated export is used")
        assert not folder.exists()  # held until the command makes its folder
        folder.mkdir()
        warnings.warn(NumbaPerformanceWarning("parallel=True had no effect"))
    assert shown == ["a truncated export is used"]
    log = (folder / LOG_NAME).read_text().splitlines()
    assert [line.split(":")[0] for line in log] == ["NumbaIRAssumptionWarning", "drake",
                                                   "NumbaPerformanceWarning"]
    assert PEDANTIC in log[0] and "WARNING: Meshcat listening" in log[1]
    # left, as before: the drake logger is pydrake's own again
    assert not any(isinstance(h, third_party_noise._ToLog)
                   for h in logging.getLogger("drake").handlers)
    assert third_party_noise.log_path() is None


def test_a_commands_noise_goes_to_its_output_folder_and_its_warnings_to_the_console(
        tmp_path, monkeypatch, capsys):
    def noisy(args):
        from safety_systems.files.output_files import prepare_out

        warnings.warn(NumbaIRAssumptionWarning(PEDANTIC))
        prepare_out(args.out)
        warnings.warn("capture glitches: 3 samples of technician/head read as untracked")
        return 0

    monkeypatch.setattr(cli, "_simulate", noisy)
    assert cli.main(["simulate", "x.yaml", "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "Please report" not in err and "numba" not in err
    assert ("safety-systems: warning: capture glitches: 3 samples of technician/head read as "
            "untracked") in err
    assert PEDANTIC in (tmp_path / "o" / LOG_NAME).read_text()


def test_worker_processes_keep_noise_in_the_log_and_leave_ctrl_c_to_the_command(tmp_path):
    from verification.search.runner import Runner

    (tmp_path / "out").mkdir()
    with kept_in(tmp_path / "out" / LOG_NAME), Runner(workers=2) as runner:
        runner.map(warnings.warn, [(NumbaIRAssumptionWarning(f"{PEDANTIC} ({i})"),)
                                   for i in range(2)])
        handlers = runner.map(signal.getsignal, [(signal.SIGINT,)] * 2)
    assert handlers == [signal.SIG_IGN] * 2
    log = (tmp_path / "out" / LOG_NAME).read_text()
    assert f"{PEDANTIC} (0)" in log and f"{PEDANTIC} (1)" in log and "\x1b" not in log
