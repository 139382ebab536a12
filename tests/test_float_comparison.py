"""The cross-processor comparison of ``helpers.floats`` accepts float rounding and nothing more."""

import json

from helpers.floats import file_mismatches, mismatches, text_mismatches


def test_last_bits_of_a_full_precision_float_pass_and_a_real_change_does_not():
    stored = {"legibility": 0.6271999394945349, "n": 100, "holds": True, "lo": [0.01, -0.022188094163000372]}
    other_cpu = {"legibility": 0.6271999394945347, "n": 100, "holds": True, "lo": [0.01, -0.02218809416300031]}
    assert not mismatches(other_cpu, stored)
    assert mismatches({**other_cpu, "legibility": 0.6271999394945347 * (1 + 1e-7)}, stored)
    assert mismatches({**other_cpu, "n": 101}, stored)
    assert mismatches({**other_cpu, "holds": False}, stored)
    assert mismatches({**other_cpu, "holds": 1}, stored)  # a bool is not a number
    assert mismatches({k: v for k, v in other_cpu.items() if k != "lo"}, stored)
    assert mismatches({**other_cpu, "lo": [0.01]}, stored)


def test_a_number_printed_rounded_may_flip_its_last_digit_only():
    stored = "| Diffusion Policy | 0.45 ± 0.09 | -0.000 [-0.012, 0.011] |"
    assert not text_mismatches("| Diffusion Policy | 0.46 ± 0.09 | 0.000 [-0.012, 0.011] |", stored)
    assert text_mismatches("| Diffusion Policy | 0.47 ± 0.09 | -0.000 [-0.012, 0.011] |", stored)
    assert text_mismatches("| Diffusion Policy | 0.45 ± 0.09 | -0.000 [-0.012, 0.021] |", stored)
    assert text_mismatches("| Diffusion policy | 0.45 ± 0.09 | -0.000 [-0.012, 0.011] |", stored)
    assert text_mismatches("| Diffusion Policy | 0.45 ± 0.09 | -0.000 [-0.012, 0.011] | 1 |", stored)
    # a full-precision number printed in text is held to the float tolerance, not to its last digit
    assert text_mismatches("x = 0.62719993", "x = 0.62719994")  # 1.6e-8 relative: beyond rounding
    assert not text_mismatches("x = 0.6271999394945347", "x = 0.6271999394945349")


def test_json_files_are_compared_parsed_and_other_files_as_text():
    stored = json.dumps({"claim": "SCDP beats DP", "mean": 0.503, "d": 0.1 + 0.2})
    assert not file_mismatches(json.dumps({"claim": "SCDP beats DP", "mean": 0.504, "d": 0.3}), stored, "claims.json")
    assert file_mismatches(json.dumps({"claim": "SCDP beats LD", "mean": 0.503, "d": 0.3}), stored, "claims.json")
    assert file_mismatches(json.dumps({"claim": "SCDP beats DP", "mean": 0.505, "d": 0.3}), stored, "claims.json")
    assert file_mismatches("0.3", "0.30000000000000004", "report.md") == []
    assert file_mismatches("0.3 s", "0.3 m", "report.md")
