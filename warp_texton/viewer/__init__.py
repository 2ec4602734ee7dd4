"""The viewer page (HTML, JavaScript, CSS) served by :mod:`warp_texton.view`; package data only."""
