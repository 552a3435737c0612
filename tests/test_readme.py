"""The README's results table is what `benchmarks/results_table.py` builds from the result files."""

from conftest import ROOT, benchmark_script


def test_the_readme_results_table_is_built_from_the_committed_result_files():
    results_table = benchmark_script("results_table")
    table = results_table.table()
    assert len(table.splitlines()) == 2 + len(results_table.FILES)
    assert table in (ROOT / "README.md").read_text()
