"""Where a sweep's tiles go and what is read back: the interface every output shares and
the write error (:mod:`.store`), a directory of netCDF tiles (:mod:`.directory`), a zarr
store (:mod:`.zarr_store`) and its export as one netCDF file (:mod:`.zarr_export`), the
directory of a refined sweep (:mod:`.refined`), merging tiles into one dataset
(:mod:`.merge`), checking an output (:mod:`.verify`), the outcome of each launch
(:mod:`.outcomes`) and the comparison of a refined map with a full one (:mod:`.compare`)."""
