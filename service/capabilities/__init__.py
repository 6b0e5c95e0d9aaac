"""The capabilities, each declaring its operations once (:mod:`plotgate.service.table`
gathers them). A declaration module imports the wire schemas only: handlers, field maps
and scene drawers are named, and imported where they are first used."""
