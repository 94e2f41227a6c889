"""Reading a store back for people: results, attention, verdicts, charts, HTML and run text.

``fleet_results`` and ``fleet_summary`` are tables; ``write_report`` writes the HTML report.
"""
