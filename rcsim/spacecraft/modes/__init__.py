"""Beyond the rigid body: propellant slosh and hinged appendages as child bodies of the hub.

A vehicle file's ``[[slosh]]`` and ``[[appendage]]`` blocks (``docs/vehicles.md``, "Slosh and
appendages") become MuJoCo child bodies of the vehicle body, each on its own joints with a
spring and a damper.  The vehicle body is then the *rigid part* (the hub): the file's
``[mass]`` is the whole wet vehicle with every mode at rest, and the hub is what remains when
the modes' masses are taken out (:func:`rcsim.spacecraft.modes.definition.hub_mass_properties`),
so the total mass, CG and inertia stay the file's.

* :mod:`~rcsim.spacecraft.modes.definition`: the modes (:class:`SloshMode`,
  :class:`Appendage`), their springs and dampers, the hub's mass properties;
* :mod:`~rcsim.spacecraft.modes.reader`: the file's blocks, checked (one-line errors);
* :mod:`~rcsim.spacecraft.modes.mjcf`: their MJCF, and the flight model's copy of them;
* :mod:`~rcsim.spacecraft.modes.linear`: clamped and coupled frequencies, effective masses
  (``rcsim vehicle check``).

A vehicle without these blocks builds exactly the model it always did.
"""

from rcsim.spacecraft.modes.definition import Appendage, SloshMode

__all__ = ["Appendage", "SloshMode"]
