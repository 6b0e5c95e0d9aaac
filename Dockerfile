# plotgate service image: docker build -t plotgate . && docker run -p 8000:8000 -v "$PWD/recordings:/data" plotgate
FROM python:3.11-slim AS builder
ENV PYTHONDONTWRITEBYTECODE=1 PIP_DISABLE_PIP_VERSION_CHECK=1
WORKDIR /build
RUN python -m venv /opt/venv
# Dependencies first, from pyproject.toml alone, so code changes keep this layer cached.
COPY pyproject.toml README.md LICENSE ./
# empty packages where pyproject.toml's package list and package-dir put them
RUN python -c "import tomllib, pathlib; c = tomllib.load(open('pyproject.toml', 'rb'))['tool']['setuptools']; roots = c['package-dir']; [pathlib.Path(roots[r], *p[len(r):].split('.')).mkdir(parents=True, exist_ok=True) or pathlib.Path(roots[r], *p[len(r):].split('.'), '__init__.py').touch() for p in c['packages'] for r in [max((k for k in roots if p == k or p.startswith(k + '.')), key=len)]]" \
    && touch plotgate/py.typed \
    && /opt/venv/bin/pip install --no-cache-dir ".[cluster]" \
    && /opt/venv/bin/pip uninstall -y plotgate \
    && rm -rf plotgate core service clients build *.egg-info
COPY plotgate ./plotgate
COPY core ./core
COPY service ./service
COPY clients ./clients
RUN /opt/venv/bin/pip install --no-cache-dir --no-deps .

FROM python:3.11-slim
ARG GIT_COMMIT=unknown
RUN adduser --disabled-password --gecos "" --uid 10001 plotgate \
    && mkdir /data /var/cache/plotgate && chown plotgate:plotgate /data /var/cache/plotgate
COPY --from=builder /opt/venv /opt/venv
ENV PATH=/opt/venv/bin:$PATH \
    PYTHONUNBUFFERED=1 \
    PLOTGATE_HOST=0.0.0.0 \
    PLOTGATE_ALLOW_UNAUTHENTICATED=true \
    PLOTGATE_PORT=8000 \
    PLOTGATE_LOG_DIR=/data \
    PLOTGATE_GIT_COMMIT=$GIT_COMMIT \
    NUMBA_CACHE_DIR=/var/cache/plotgate/numba
VOLUME ["/data"]
WORKDIR /data
USER plotgate
# compile the numba kernels now, as the user that serves, into a cache it can write:
# a container starts warm (plotgate.core.compiled; the registry imports operations lazily,
# load_all imports every one); the second import must compile nothing, or the cache was
# not kept and every container would compile in its warm-up (service/warmup.py)
RUN python -c "from plotgate.service.registry import load_all; load_all()" \
 && python -c "from plotgate.service.kernels import load_kernels; \
assert load_kernels(lambda: None) is None, 'the kernel cache was not kept'"
EXPOSE 8000
HEALTHCHECK --interval=10s --timeout=3s \
    CMD ["python", "-c", "import urllib.request; urllib.request.urlopen('http://127.0.0.1:8000/healthz', timeout=2)"]
CMD ["plotgate", "serve"]
