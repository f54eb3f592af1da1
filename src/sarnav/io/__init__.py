"""sarnav.io: NGA standard files through sarkit (MIT; the maintained successor of sarpy), GeoTIFF through rasterio
(the optional extra ``sarnav[geo]``).

- ``frames``: the local NED frame of the simulations <-> WGS-84 ECEF at a geodetic reference point
- ``cphd``: write a collect (raw or range-compressed pulses) as CPHD 1.0.1, read a CPHD into
  ``PulseData`` plus its default image grid (:func:`cphd.write_collect`, :func:`cphd.read_collect`)
- ``cphd_read``, ``cphd_checks``: any vendor CPHD's checked header, PVPs and signal blocks (one channel, a range of
  vectors; every uncompressed format, AmpSF, SGN, TDTropoSRP), one-line errors naming the file's field
- ``cphd_stream``: the BPA / FFBP image of a CPHD formed in blocks of vectors within a memory budget
- ``sicd``: write a back-projected image as SICD 1.3.0 with its geometry (:func:`sicd.write_image`); read any SICD
  with its SICD Volume 3 projection (:func:`sicd.read_sicd` -> ``SicdProduct``, in ``sicd_product``)
- ``geotiff``: GeoTIFF orthoimages and DEMs read (:func:`geotiff.read_orthoimage`, :func:`geotiff.read_dem`) and
  written (:func:`geotiff.write_geotiff`; :func:`geotiff.write_plane_geotiff`, ``sarnav image FILE.cphd --geotiff``)

docs/io.md lists the fields written and how to validate the files (``cphdcheck``, ``sicdcheck``).
"""
