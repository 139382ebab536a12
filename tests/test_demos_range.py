"""The training data's range of D, E and j beside a run's demos: computed once and kept by the commands
that make a run, read (and, when missing, computed) without writing by those that only read one."""

from scdp.pipeline.stages import RANGE_FILE, demos_range


def test_a_reading_command_writes_nothing_into_the_run_and_a_making_one_keeps_the_range(small_datasets, tmp_path):
    demos = small_datasets["navigation"]
    demos.save(tmp_path / "demos.zarr")
    read = demos_range(tmp_path, keep=False)  # scdp verify: the run is not its to change
    assert read is not None and not (tmp_path / RANGE_FILE).exists()
    kept = demos_range(tmp_path)  # reproduce's demos stage
    assert (tmp_path / RANGE_FILE).is_file() and kept == read and kept.demos == demos.num_episodes
    assert demos_range(tmp_path / "none") is None
