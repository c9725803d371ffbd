"""Modal translations phi and small rotations psi of a frame on a link.

For each mode, the 6-DOF motion [t; theta] of an interface's origin:

* RBE2 interface of the tied model: its master DOFs (exact rigid motion);
* RBE3 interface or marker on a solid: the least-squares rigid fit of the
  nodal displacements (:func:`pipeline.fem.rigid_fit.rigid_fit_operator`);
* beam: the node's translations and rotations carried to the origin by a
  rigid offset.

Everything is in the link frame (the frame the geometry was described in);
the artifact builder rotates it to the body frame.
"""

from __future__ import annotations

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import Interface, TiedModel, interface_operator
from pipeline.fem.model import FemModel
from pipeline.modes.basis import ModalBasis


def frame_motion(model: FemModel, tied: TiedModel, basis: ModalBasis,
                 interface: Interface | str) -> tuple[np.ndarray, np.ndarray]:
    """Translation and small rotation of each mode at an interface origin.

    Parameters
    ----------
    model : FemModel the basis was computed on (unreduced).
    tied : TiedModel the basis was computed from.
    basis : ModalBasis with m modes.
    interface : an Interface of ``tied`` (or its name), or any Interface used
        as a marker (its nodes are fitted rigidly).

    Returns
    -------
    phi : (m, 3) translation of the origin per unit modal coordinate, m.
    psi : (m, 3) small rotation per unit modal coordinate, rad.

    Raises
    ------
    ConfigError
        Unknown interface name, or a basis that does not belong to the model.
    """
    if basis.shapes.shape[0] != model.n_dof or basis.reduced_shapes.shape[0] != tied.n_red:
        raise ConfigError(f"link {model.name!r}: frame motion: the modal basis "
                          f"({basis.shapes.shape[0]} DOFs) does not belong to this model "
                          f"({model.n_dof} DOFs)")
    itf = tied.interface(interface) if isinstance(interface, str) else interface
    tied_itf = next((i for i in tied.interfaces if i.name == itf.name), None)
    if itf.kind == "rbe2" and tied_itf is not None and tied_itf.nodes.size == itf.nodes.size \
            and np.array_equal(tied_itf.nodes, itf.nodes):
        motion = basis.reduced_shapes[tied.master_dofs[itf.name]]  # (6, m)
    else:
        motion = np.asarray(interface_operator(model, itf) @ basis.shapes)
    return motion[:3].T.copy(), motion[3:].T.copy()
