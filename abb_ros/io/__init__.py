"""Files: MCAP bags, scenario files and plots."""
