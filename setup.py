"""Which packages the wheel holds: found automatically under each source folder.

drivers/ and simulators/ stay top-level folders but install as ``ecds_lab.drivers`` and
``ecds_lab.simulators`` (no generic top-level import name lands in site-packages), and
experiments/ installs as ``ecds_lab.experiments`` with its YAML as package data. setuptools'
``find`` cannot add a name prefix, so the prefix is added here; everything else is in pyproject.toml.
"""

from setuptools import find_packages, setup

#: Import name -> source folder. Every package below a folder is found and installed under its name.
ROOTS = {
    "ecds_lab": "ecds_lab",
    "ecds_lab.drivers": "drivers",
    "ecds_lab.simulators": "simulators",
    "ecds_lab.experiments": "experiments",
}

packages = []
for name, folder in ROOTS.items():
    packages.append(name)
    packages += [f"{name}.{sub}" for sub in find_packages(folder)]

setup(
    package_dir={name: folder for name, folder in ROOTS.items()},
    packages=packages,
    package_data={"ecds_lab": ["py.typed"], "ecds_lab.experiments": ["*.yaml", "*/*.yaml"]},
)
