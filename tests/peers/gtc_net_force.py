"""The GUM Tree Calculator (GTC 1.5.1) on a cylinder's net force from its
two chamber pressures: the head transducer's certificate line fitted by
GTC's own type_a.line_fit (no stated uncertainties, n - 2 degrees of
freedom), evaluated at the reading that gives the hold's mean; the rod
transducer's accuracy class, rectangular (type_b.uniform); each hold's
scatter as a ureal with n_eff - 1 degrees of freedom. Reads one JSON
object (argv[1]), prints {"u_c", "dof", "k"}. Used by tests/budget.rs."""
import json, math, sys

from GTC import dof, type_a, type_b, uncertainty, ureal, value
from GTC.reporting import k_factor

given = json.load(open(sys.argv[1]))
head, rod = given["head"], given["rod"]

readings = [p[0] for p in given["curve_points"]]
values = [p[1] for p in given["curve_points"]]
a, b = type_a.line_fit(readings, values).a_b
at = (head["mean"] - value(a)) / value(b)
curve = a + b * at
head_pressure = (
    ureal(head["mean"], head["std"] / math.sqrt(head["n_eff"]), head["n_eff"] - 1)
    + (curve - value(curve))
)
rod_pressure = ureal(
    rod["mean"], rod["std"] / math.sqrt(rod["n_eff"]), rod["n_eff"] - 1
) + ureal(0.0, type_b.uniform(rod["accuracy_half_width"]))
net = given["head_kn_per_bar"] * head_pressure - given["rod_kn_per_bar"] * rod_pressure
print(json.dumps({"u_c": uncertainty(net), "dof": dof(net), "k": k_factor(dof(net))}))
