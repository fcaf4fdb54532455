"""The window's background work: cage and binding builds, and polish on release.

Modules
-------
build_worker     : the thread that reads a mesh and builds its cage and binding
build_jobs       : one build at a time: progress, cancel, the cage size it uses, the message it ends with
polish_worker    : the thread that polishes the edited region at full resolution
polish_scheduler : one polish at a time: queue, cancel, current results only
threads          : letting a finished worker thread go
"""
