"""Print docs/parameters.md, generated from the parameter specs.

    .venv/bin/python scripts/make_parameters_doc.py > docs/parameters.md

The table is :func:`abb_ros.nodes.ros.parameter_table.markdown` with the command line's mapping
(:func:`abb_ros.commands.settings.commands_taking`) for its ``abb-sim --set`` column; the two
layers do not import each other, so this script joins them.
test/model/parameters/test_param_spec.py compares.
"""

import sys

from abb_ros.commands.settings import commands_taking
from abb_ros.nodes.ros.parameter_table import markdown

if __name__ == '__main__':
    sys.stdout.write(markdown(commands_taking))
