# One image for every process of an arena (server, coach, players, trainer): `docker compose up`.
FROM python:3.11-slim
WORKDIR /keepaway
COPY pyproject.toml README.md ./
COPY keepaway ./keepaway
COPY protocol ./protocol
COPY server ./server
COPY agents ./agents
COPY coach ./coach
COPY trainer ./trainer
RUN pip install --no-cache-dir . \
    && python -c "from agents.player import compile_kernels; compile_kernels()"
ENTRYPOINT ["keepaway"]
