from pipeline.warmup import warm_up


def test_the_warm_up_runs_every_compiled_loop_and_finds_its_pad():
    assert warm_up() > 0.0  # (it raises when the pad is not found)
