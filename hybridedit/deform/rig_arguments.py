"""The rig an editor works on, from its first arguments: the :class:`~hybridedit.binding.rig.Rig` it
is given, or one built from a Mesh with the build options given; a build option given with a Rig
is refused, told apart from its default by the :class:`BuildDefault` sentinel."""

from __future__ import annotations

from ..binding.rig import Rig, build_rig
from ..core.mesh import Mesh

__all__ = ["BuildDefault", "rig_from"]


class BuildDefault:
    """A build option's default (shown as its value in the signature), told apart from the same value
    given explicitly: :class:`~hybridedit.HybridEditor` refuses build options given with a ready :class:`Rig`."""

    __slots__ = ("value",)

    def __init__(self, value) -> None:
        self.value = value

    def __repr__(self) -> str:
        return repr(self.value)


def rig_from(mesh: Mesh | Rig, **build) -> Rig:
    """``mesh`` itself when it is a :class:`Rig`, else :func:`~hybridedit.binding.rig.build_rig` of it.

    Parameters
    ----------
    mesh : Mesh or Rig
    **build
        :func:`~hybridedit.binding.rig.build_rig`'s options, each a value or a :class:`BuildDefault`
        (one not given).

    Raises
    ------
    ValueError
        A build option given (not a :class:`BuildDefault`) with a Rig: it is built already.
    """
    if isinstance(mesh, Rig):
        given = [k for k, v in build.items() if not isinstance(v, BuildDefault)]
        if given:
            raise ValueError(f"{', '.join(given)} cannot be given with a Rig (it is built already); "
                             "pass them to build_rig, or pass the Mesh")
        return mesh
    return build_rig(mesh, **{k: v.value if isinstance(v, BuildDefault) else v for k, v in build.items()})
