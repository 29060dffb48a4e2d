"""A pot's record as a smelter's historian exports it, turned into the data contract.

The flow, one module a step:

- :mod:`.tags`: the tag map (YAML): which historian tag is which channel or input, which is an
  event, and in which unit (converted with pint);
- :mod:`.read`: the export (long: ``timestamp, tag, value[, quality]``; or wide: a timestamp and
  a column a tag), the events log and the lab's samples, each stamp as UTC;
- :mod:`.grid`: onto the model's step: values averaged within a step, a gap left empty, the record
  cut where an input is missing longer than ``max_gap_s``, anode effects left out, events placed on
  the record's clock;
- :mod:`.report`: what was kept, dropped, blanked and cut, in words and one plot a channel.

:func:`import_historian` runs them; its tables are the data contract's (:mod:`costa.data`,
:mod:`costa.events`), ready for ``discovery.user_data``.  A bad export stops with one
:class:`ExportError` naming the file, the tag and the row.
"""

from .grid import GridSettings, Imported, import_historian
from .read import ExportError
from .tags import TagMap, read_tag_map

__all__ = ["ExportError", "GridSettings", "Imported", "TagMap", "import_historian", "read_tag_map"]
