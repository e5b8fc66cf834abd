"""The live view of a run: a local web page that follows a run file as it grows (``ecds-lab watch``).

snapshot  what the file holds now (read through SWMR), with progress, ETA and the latest readings
figures   the PNG plots the page shows (matplotlib, drawn on the server)
page      the HTML page and its few lines of polling JavaScript (no CDN, nothing fetched elsewhere)
server    the standard library's ThreadingHTTPServer on 127.0.0.1 serving page, JSON status and PNGs
"""
