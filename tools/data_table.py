"""Reads the data tables of tools/data/ that the generators use: CSV files whose
lines starting with '#' say what the table is and where it comes from, then a
header line naming the columns, then one row of numbers per line."""
import os

DATA_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")


def read_columns(name):
    """The columns of tools/data/NAME by their header names, as lists of floats."""
    with open(os.path.join(DATA_DIR, name)) as f:
        rows = [line.strip().split(",") for line in f if line.strip() and not line.startswith("#")]
    return {col: [float(r[i]) for r in rows[1:]] for i, col in enumerate(rows[0])}
