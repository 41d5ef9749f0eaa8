"""Corpus rows for inputs that already had one clear line before issue 13."""

from tests.corpus import Hostile, config, step_csv

CSV = "time,u,y\n"

CASES = [
    Hostile("missing_config", ("run", "nope.yaml"), 2, stderr=("nope.yaml",)),
    Hostile("config_not_yaml", ("run", "c.yaml"), 2, files={"c.yaml": "name: [unclosed\n"},
            stderr=("c.yaml",)),
    Hostile("config_unknown_key", ("run", "c.yaml"), 2,
            files={"c.yaml": config("path: log.csv\ninptu: u"), "log.csv": step_csv()},
            stderr=("data.inptu",)),
    Hostile("csv_missing_column", ("identify", "log.csv", "--input", "v", "--output", "y"), 2,
            files={"log.csv": step_csv()}, stderr=("log.csv",)),
    Hostile("csv_empty", ("identify", "log.csv", "--input", "u", "--output", "y"), 2,
            files={"log.csv": ""}, stderr=("log.csv",)),
    Hostile("csv_header_only", ("identify", "log.csv", "--input", "u", "--output", "y"), 2,
            files={"log.csv": CSV}, stderr=("log.csv",)),
    Hostile("csv_binary_garbage", ("identify", "log.csv", "--input", "u", "--output", "y"), 2,
            files={"log.csv": bytes(range(256)) * 8}, stderr=("log.csv",)),
    Hostile("good_csv_identifies", ("identify", "log.csv", "--input", "u", "--output", "y",
                                    "--time", "time", "--method", "first_order"), 0,
            files={"log.csv": step_csv()}, max_lines=0),
]
