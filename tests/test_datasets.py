"""The dataset catalogue (refimpl.datasets) is the one list of dataset names: it holds exactly
refimpl.io's benchmark files plus the simulated datasets refimpl.simulate can make."""

from __future__ import annotations

import pytest

from refimpl import io
from refimpl.datasets import CATALOGUE, DATASETS, SIMULATED, SIMULATED_SUFFIX, TABLE6_DATASETS, dataset
from refimpl.simulate import SIMULATED_BENCHMARKS


def test_the_catalogue_is_io_benchmarks_plus_the_simulated_ones():
    assert set(DATASETS) - set(SIMULATED) == set(io.BENCHMARKS)
    assert {n[: -len(SIMULATED_SUFFIX)] for n in SIMULATED} == set(SIMULATED_BENCHMARKS)
    assert set(TABLE6_DATASETS) <= set(DATASETS)
    # a simulated dataset says so in its title, wherever a table prints it
    assert all(("SIMULATED" in CATALOGUE[n].title) == CATALOGUE[n].simulated for n in DATASETS)


def test_an_unknown_dataset_names_the_known_ones():
    with pytest.raises(ValueError, match="unknown dataset 'bogus' .*mot15"):
        dataset("bogus")
