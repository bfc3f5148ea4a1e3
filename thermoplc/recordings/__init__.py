"""Reading recordings: CSV, .npz and Parquet tables, campaigns of runs, raw logger data resampled."""
