"""The labs' kit: finding and checking labs, wrong and right variants, the grader and its sandbox."""
