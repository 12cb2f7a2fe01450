# Development and CI image: Debian 12 with every dependency from .ci/setup.
# Not built by CI (no Docker engine on the build machines); `bash .ci/test` is the CI path.
#   docker build -f docker/build.Dockerfile -t terrain-build .
#   docker run --rm -v "$PWD:/src" -w /src terrain-build bash .ci/test
FROM debian:12
COPY .ci/setup /tmp/setup
RUN bash /tmp/setup && rm -rf /var/lib/apt/lists/*
