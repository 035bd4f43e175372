"""Local processes and a Dask cluster (here on loopback) give the in-process figures."""

import numpy as np
import pytest
from dask.distributed import LocalCluster

from safety_systems.config.scenario import load_controller_config
from verification.search.evaluate_batch import evaluate_many
from verification.search.runner import Runner
from verification.spaces.space import free_parameters, load_space, make_scenario, to_point

SPACE = load_space("models/spaces/default.yaml")


@pytest.fixture(scope="module")
def scenarios():
    config = load_controller_config("models/configs/seed_estimated.yaml")
    rng = np.random.default_rng(2)
    d = len(free_parameters(SPACE))
    return [make_scenario(SPACE, config, to_point(SPACE, rng.uniform(size=d))) for _ in range(4)]


def test_processes_and_dask_agree_with_in_process(scenarios):
    expected = evaluate_many(scenarios).robustness
    with Runner(workers=2, chunk=2) as runner:
        np.testing.assert_array_equal(runner.evaluate(scenarios)[:, 0], expected)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        with Runner(scheduler=cluster.scheduler_address, chunk=2) as runner:
            figures = runner.evaluate(scenarios)
    np.testing.assert_array_equal(figures[:, 0], expected)


def test_repeated_scenarios_run_once(scenarios, tmp_path):
    cache = tmp_path / "cache.jsonl"
    with Runner(workers=1, cache_path=cache) as runner:
        figures = runner.evaluate(scenarios[:2] + scenarios[:2])
    assert len(cache.read_text().splitlines()) == 2
    np.testing.assert_array_equal(figures[:2], figures[2:])


def test_check_scheduler_accepts_a_scheduler_and_refuses_anything_else():
    import socket
    import threading

    from safety_systems.files.input_error import InputError
    from verification.search.runner import check_scheduler

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        check_scheduler(cluster.scheduler_address, timeout=5.0)
    # A server that answers with bytes that are not Dask's protocol.
    server = socket.create_server(("127.0.0.1", 0))
    port = server.getsockname()[1]

    def answer():
        connection, _ = server.accept()
        with connection:
            connection.sendall(b"HTTP/1.1 400 Bad Request\r\n\r\n" + b"\xff" * 64)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    try:
        with pytest.raises(InputError) as e:
            check_scheduler(f"tcp://127.0.0.1:{port}", timeout=2.0)
    finally:
        server.close()
        thread.join(timeout=5.0)
    assert e.value.field == "--scheduler" and "\n" not in str(e.value)
