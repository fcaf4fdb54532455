"""The toolbar's cage size box: a number and a unit (% of the shape's vertices, or vertices).

The size a build uses is fitted to its shape by :func:`~hybridedit.viewer.model.cage_size.fit_cage_size`.
"""

from __future__ import annotations

from typing import Callable

from qtpy import QtWidgets

from ..model.cage_size import DEFAULT_SIZE, is_count

PERCENT, VERTICES = 0, 1


class CageSizeControl(QtWidgets.QWidget):
    """A spin box and a unit box; :meth:`value` is a float fraction or an int vertex count.

    Parameters
    ----------
    shape_vertices : returns the current shape's vertex count (or None), used to
        convert the number when the unit changes.

    Attributes
    ----------
    of_shape : the box shows the cage size of the shape on display (``set_value(..., of_shape=True)``),
        not a size chosen since (typed, or set otherwise): a vertex count of that kind is not carried
        over to another shape.
    """

    def __init__(self, shape_vertices: Callable[[], int | None], parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._shape_vertices = shape_vertices
        self.spin = QtWidgets.QDoubleSpinBox()
        self.spin.setKeyboardTracking(False)
        self.spin.setToolTip("Cage size: a percentage of the shape's vertices, or a vertex count")
        self.unit = QtWidgets.QComboBox()
        self.unit.addItems(["%", "vertices"])
        self.unit.currentIndexChanged.connect(self._unit_changed)
        self.of_shape = False
        self._setting = False
        self.spin.valueChanged.connect(self._edited)  # (arrows, wheel)
        self.spin.lineEdit().textEdited.connect(self._edited)  # (typing, also the number already there)
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(2)
        layout.addWidget(self.spin)
        layout.addWidget(self.unit)
        self.set_value(DEFAULT_SIZE)

    def value(self) -> int | float:
        """An int vertex count, or a float fraction in (0, 1]."""
        if self.unit.currentIndex() == PERCENT:
            return float(self.spin.value()) / 100.0
        return int(round(self.spin.value()))

    def set_value(self, size: int | float, *, of_shape: bool = False) -> None:
        """Show ``size``: an int vertex count, or a float fraction (shown in %); ``of_shape``: it is the
        size of the cage on display (see :attr:`of_shape`)."""
        self._setting = True
        self.unit.blockSignals(True)
        if is_count(size):
            self.unit.setCurrentIndex(VERTICES)
            self._range(VERTICES)
            self.spin.setValue(int(size))
        else:
            self.unit.setCurrentIndex(PERCENT)
            self._range(PERCENT)
            self.spin.setValue(float(size) * 100.0)
        self.unit.blockSignals(False)
        self._setting = False
        self.of_shape = of_shape

    def _edited(self, *_args) -> None:
        if not self._setting:
            self.of_shape = False  # (a size chosen by hand)

    def _range(self, unit: int) -> None:
        if unit == VERTICES:
            self.spin.setDecimals(0)
            self.spin.setRange(4, 10_000_000)
            self.spin.setSingleStep(100)
        else:
            self.spin.setDecimals(2)
            self.spin.setRange(0.01, 100.0)
            self.spin.setSingleStep(0.5)

    def _unit_changed(self, unit: int) -> None:
        self.of_shape = False
        n = self._shape_vertices()
        old = self.spin.value()
        self._range(unit)
        if unit == VERTICES:  # % -> vertices
            self.spin.setValue(round(old / 100.0 * n) if n else 2000)
        else:
            self.spin.setValue(min(100.0, 100.0 * old / n) if n else 5.0)
