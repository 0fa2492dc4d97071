"""Lower bounds on the commands of traces and tours, over the arm's whole solution family.

A command moves joint ``j`` by at most its largest step ``m_j``, so a motion from ``q`` to
``q'`` takes at least ``max_j |q'_j - q_j| / m_j`` commands: the largest-joint (Chebyshev)
distance in *command units* ``u_j = q_j / m_j`` (revolute joints whose range spans a whole
turn the shorter way round). Only
the joints that move the tool point count (the others turn the tool about it).

A trace's pass brings the tool point within the tolerance of every point of the curve, in
order; a tour puts it within the tolerance of every target. Every configuration that does so
belongs to the solution family there (:class:`~armpath.planning.trace.family.CurveFamily`), and
a plan's must also be clear of the obstacles. So the commands are at least the length of a
shortest path from the start through the family at a few *sites* (curve points; targets), in
the Chebyshev metric, through the members that may be clear; the moves between sites ignore
the obstacles (a relaxation, so the bound holds whatever the scene).

A leg from the start to a site inside a hollow obstacle also carries the tool point across
one of the obstacle's openings, where the arm is clear (:mod:`~armpath.planning.bounds.passage`):
its cost is at least the shortest way through the family sampled over the opening's disc, and
the bound takes that where it is more than the direct distance.

The family is sampled over tool directions (:mod:`~armpath.planning.bounds.sampling`); each
sample stands for the members of the directions around it and carries a per-joint *sampling
error*: the largest difference to the nearest member of each neighbouring direction (Delaunay
neighbours on the sphere of directions), plus the joint change that moves the tool point by the
tolerance (pseudo-inverse of the position Jacobian); a sample by a fold, where a neighbouring
direction has fewer real solutions than its own and no member near it (two branches meet and
end there, parting as the square root of the distance), adds half its difference to the
sibling it meets. Distances between samples are taken less
both samples' errors (:mod:`~armpath.planning.bounds.metric`), so the shortest path through the
samples is, up to that error estimate, no longer than any path through the family. A sample is
dropped only when no member of its cell can be clear: a link's slack to an obstacle is worse
than the farther of its ends moves to its neighbours (a link pair's: both links' together;
the UR5 circle's least approach had kept members with the upper arm 45-70 mm in the table, the
wrist swinging 90 mm between them: 50 -> 51 commands), or the end of its last link's body
(where the bare tool tip begins) lies too close to an obstacle for any direction of its cell,
that end moving far less than the link's other end
(:class:`~armpath.planning.bounds.sampling.ToolBody`: the seed crack's bound 130 -> 134
commands, its tool near tangent to the workpiece at the ends of the reachable arc). The
relaxation is then searched by branch and bound over the direction cells
(:mod:`~armpath.planning.bounds.search`): a path through samples that are clear themselves
bounds the relaxation's optimum from above, the cells that cannot hold a cheaper path are
dropped, and the cells where the bound runs are split where their error or their clearance is
unsure (a cell kept only for what its neighbours allow may collide whole). The error estimate
assumes the family varies no faster inside a direction cell than between neighbouring samples;
the tests check the bounds against differently computed ones (SLSQP over the exact family; the
exactly clear members of a fine sampling), the relaxations' programmes against brute force, and
the plans.

The assumption is also audited where a bound is computed: at up to six of its sites,
members drawn another way that are clear must each lie within some sample's error box
(:meth:`FamilySampler.audit`): every solution of the arm's all-solutions IK at random tool
frames, or where it has none, the tool point alone solved from random starts. Where one does
not, the bound is reported as an estimate that says so: a five-joint SO-101's direction
barely turns along one of its family's two dimensions, so the directions chart that
dimension far too coarsely, and its welds' sampled bound, 45 commands, lay above a tour of
31. A tour then takes the relaxation over its lattice goal states, all listed, with a larger
budget (27 there, proven), and a bound that a plan undercuts is reported as refuted.

That assumption fails at a singular direction where a whole curve of members shares one tool
direction (a six-joint arm with its wrist straight): however small, a cell touching it spans
the curve. The sites' directions are sampled in a chart that blows each such direction up into
a circle of azimuths (:mod:`~armpath.planning.bounds.chart`), whose cells shrink when split
like any other (the UR5 cell's welds: 64 -> 87 commands).

An arm with more joints than a tool frame needs has one member of its self-motion sampled per
tool direction, and its bound is then an estimate, not a proof. An arm on a linear track gets a
proven one of another kind (:mod:`~armpath.planning.bounds.carriage`): the travel its carriage
needs to bring every point within the arm's reach of it, a largest distance proven by branch
and bound over the arm's joints (:mod:`~armpath.planning.bounds.farthest`): from a point of
the carriage, and from the arm's first axis at the heights of the points that decide it.

Where a trace's spans lie on a circle, or near one within windows along them (an ellipse),
its bound also sees the tolerance band: a joint-linear command follows a tight curve within
it only a few millimetres (fewer where the tool point must stay out of the solid the curve
lies on: the half band). :mod:`~armpath.planning.bounds.band`
proves how far for one middle configuration (Taylor along the joint line and a Lagrangian dual),
and :mod:`~armpath.planning.bounds.band_trace` takes the largest over the family's cells at
each layer where the family is sampled along the curve (each sample's limit widened by how far
its neighbours' differ, the sampling errors' assumption): the least approach to the curve plus
the traced length, each part of it over the largest limit of the layers a command covering it
could lie between. The higher of the two bounds is reported.
"""

from armpath.planning.bounds.sampling import FamilySampler, Layer
from armpath.planning.bounds.tour import tour_bound, tour_bound_any_order, tour_bound_over_lattice
from armpath.planning.bounds.trace import trace_bound
from armpath.planning.bounds.value import CommandBound

__all__ = [
    "CommandBound",
    "FamilySampler",
    "Layer",
    "tour_bound",
    "tour_bound_any_order",
    "tour_bound_over_lattice",
    "trace_bound",
]
