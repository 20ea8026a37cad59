"""The shared checks every command relies on: input files, output names, budgets, options."""

import argparse
import os

import pytest

from labkit._files import check_input_file, check_output_file
from labkit.budget import budget, check_budget
from labkit.commands._args import integer, number
from labkit.errors import BudgetError, InputError


def test_fifo_and_directory_are_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.gcode"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"pipe.gcode: not a regular file \(a FIFO"):
        check_input_file(fifo, what="G-code file")
    with pytest.raises(InputError, match="a directory"):
        check_input_file(tmp_path)
    with pytest.raises(InputError, match="no such file; expected an existing SVG file"):
        check_input_file(tmp_path / "missing.svg", what="SVG file")


def test_output_may_not_be_an_input_even_through_a_link(tmp_path):
    src = tmp_path / "a.svg"
    src.write_text("<svg/>")
    link = tmp_path / "b.svg"
    link.symlink_to(src)
    for out in (src, link, tmp_path / "." / "a.svg"):
        with pytest.raises(InputError, match="is also the input file"):
            check_output_file(out, src)
    assert check_output_file(tmp_path / "a.gcode", src).name == "a.gcode"
    assert src.read_text() == "<svg/>"


def test_budget_names_cause_option_and_scale(monkeypatch):
    with pytest.raises(BudgetError, match=r"30,000,000 moves \(budget 20,000,000\) from 3 passes; "
                                          r"reduce --passes"):
        check_budget("moves", 30e6, cause="3 passes", option="--passes")
    with pytest.raises(BudgetError, match="nan moves"):
        check_budget("moves", float("nan"), cause="x")
    monkeypatch.setenv("LABKIT_BUDGET_SCALE", "2")
    assert budget("moves") == 40e6
    check_budget("moves", 30e6, cause="3 passes")


@pytest.mark.parametrize("text", ["inf", "-inf", "nan", "1e400", "-1", "0", "abc", "11"])
def test_number_refuses_non_finite_and_out_of_range(text):
    with pytest.raises(argparse.ArgumentTypeError, match="is not a finite number > 0 and <= 10"):
        number(0, 10, lo_open=True)(text)


def test_integer_refuses_fractions():
    assert integer(1)("7") == 7
    for text in ("2.5", "1e3", "0", "inf"):
        with pytest.raises(argparse.ArgumentTypeError, match="whole number >= 1"):
            integer(1)(text)
