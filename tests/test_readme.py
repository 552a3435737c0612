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


def test_write_replaces_only_the_table_with_the_same_header():
    results_table = benchmark_script("results_table")
    text = "intro\n\n| a | b |\n| --- | --- |\n| 1 | 2 |\n| 3 | 4 |\n\nafter\n\n| c |\n| --- |\n| 5 |\n"
    new = "| a | b |\n| --- | --- |\n| 9 | 9 |"
    assert results_table.replace_table(text, new) == \
        "intro\n\n| a | b |\n| --- | --- |\n| 9 | 9 |\n\nafter\n\n| c |\n| --- |\n| 5 |\n"
