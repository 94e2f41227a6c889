"""One-shot studies: each module is named after the result it produced.

A study scores candidates of a reading or rule against the product on simulated or recorded
data; docs and the lab's decision log quote their tables. ``axiswatch experiment`` runs a few.
"""
