"""A command's table written into a hand-written page (`files.write_section`)."""

import pytest

from mfi_drake.files import write_section


def test_a_section_is_replaced_and_the_rest_of_the_page_kept(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "intro\n<!-- BEGIN t -->\nold\nrows\n<!-- END t -->\nafter\n"
        "<!-- BEGIN u -->\nu\n<!-- END u -->\n"
    )
    write_section(str(page), "t", "| a |\n|---|\n")
    write_section(str(page), "t", "| b |\n|---|\n")  # again: idempotent markers
    assert page.read_text() == (
        "intro\n<!-- BEGIN t -->\n| b |\n|---|\n<!-- END t -->\nafter\n"
        "<!-- BEGIN u -->\nu\n<!-- END u -->\n"
    )
    assert [p.name for p in tmp_path.iterdir()] == ["page.md"]  # no temp left


def test_a_missing_section_is_an_error_naming_it_and_the_page_is_untouched(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("<!-- BEGIN t -->\nno end\n")
    with pytest.raises(ValueError, match="no section 'v'"):
        write_section(str(page), "v", "x")
    with pytest.raises(ValueError, match="no section 't'"):
        write_section(str(page), "t", "x")
    assert page.read_text() == "<!-- BEGIN t -->\nno end\n"
