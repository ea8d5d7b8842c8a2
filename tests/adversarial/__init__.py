"""The adversarial catalogue: hostile cases as data (cases/*.toml), the builders that
write their inputs (builders.py), the loader (catalogue.py) and the runner (runner.py)."""
