"""docs/python-workflow.ipynb runs top to bottom (its code cells in order, in one namespace, as a
kernel would) and reaches its own checks: the diagnosis adds steer_offset and the held-out RMSE
falls."""
import json
import os

import ndsid


def test_the_workflow_notebook_runs():
    path = os.path.join(ndsid.SOURCE_DIR, "docs", "python-workflow.ipynb")
    with open(path, encoding="utf-8") as f:
        nb = json.load(f)
    namespace = {"__name__": "__notebook__"}
    ran = 0
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        exec(compile("".join(cell["source"]), f"{path}:cell {ran}", "exec"), namespace)
        ran += 1
    assert ran >= 6
    assert "steer_offset" in namespace["dia"]["final_effects"]
    assert namespace["fitted"]["rmse_validation_mps2"] < namespace["base"]["rmse_validation_mps2"]
