"""The README's results tables are what `benchmarks/results_table.py` builds from the result files."""

from conftest import ROOT, benchmark_script


def test_the_readme_results_table_is_built_from_the_committed_result_files():
    results_table = benchmark_script("results_table")
    table = results_table.table()
    assert len(table.splitlines()) == 2 + len(results_table.FILES)
    assert table in (ROOT / "README.md").read_text()


def test_the_readme_robustness_table_is_built_from_the_shipped_policies_sweeps():
    results_table = benchmark_script("results_table")
    table = results_table.robustness_table()
    assert len(table.splitlines()) == 2 + len(results_table.ROBUSTNESS)
    assert table in (ROOT / "README.md").read_text()
