"""Files in and out: one reading module for every file, ranges, input errors, atomic writes."""
