from inspect_validate.cli import main

# Guarded: Dask's worker processes (predict --dask) re-import the main module.
if __name__ == "__main__":
    main()
