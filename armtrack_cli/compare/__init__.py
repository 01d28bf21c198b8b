"""Stage: estimates against ground truth, as error tables (Tao & Hu's Table I)."""
