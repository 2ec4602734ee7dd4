"""The viewer page (HTML, JavaScript, CSS) served by :mod:`warp_texton.view.server`; package data only."""
